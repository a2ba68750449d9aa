//! The parsed file → a checked protocol (all but its library): the checks
//! that look at more than one value, each error naming the line and field.

use std::ops::Range;

use toml::Spanned;

use super::file::{File, KindFile, OrderFile, QuestionFile, RepeatsFile, ReportFile, repeated};
use super::{
    Adjustment, Condition, Factor, Kind, MAX_CONDITIONS, MAX_OPTIONS, MAX_QUESTIONS, MAX_TRIALS,
    Order, PairSpec, Question, ReportSpec, Timeline, Unlinked,
};
use crate::error::InputError;
use crate::lab::stats::table::Repeats;
use crate::lab::study::columns::{Adaptive, AdjustColumns, Column, Columns, Holds};

pub(super) use super::errors::Errors;

/// Checks what parsing alone cannot.
pub(super) fn check(mut file: File, e: &Errors) -> Result<Unlinked, InputError> {
    let timeline = timeline(&file, e)?;
    let factors = factors(&file, e)?;
    let quest = (file.quest.take())
        .map(|q| super::quest::check(q, &file, &factors, e))
        .transpose()?;
    let start = super::staircase::start_label(&file)
        .or_else(|| quest.as_ref().map(|q| q.start_label().to_owned()));
    let conditions = conditions(&file.stimulus, &factors, start.as_deref(), e)?;
    let sets = file.sets.0;
    if conditions.len().saturating_mul(sets) > MAX_TRIALS {
        return Err(e.bad(format!(
            "{} conditions in {sets} sets make {} trials; at most {MAX_TRIALS} fit one session",
            conditions.len(),
            conditions.len().saturating_mul(sets)
        )));
    }
    if file.question.len() > MAX_QUESTIONS {
        return Err(e.bad(format!(
            "{} questions; at most {MAX_QUESTIONS}",
            file.question.len()
        )));
    }
    let mut questions: Vec<Question> = Vec::new();
    for q in file.question {
        let id = q.id.get_ref().0.clone();
        if questions.iter().any(|x| x.id == id) {
            return Err(e.at(q.id.span(), "id", format!("question `{id}`: given twice")));
        }
        questions.push(question(q, e)?);
    }
    let report = report(file.report, &factors, e)?;
    let levels_of: Vec<Vec<String>> = conditions.iter().map(|c| c.levels.clone()).collect();
    let has_adjustment = file.adjustment.is_some();
    let staircase = (file.staircase)
        .map(|s| {
            super::staircase::check(s, has_adjustment, &file.stimulus, &factors, &levels_of, e)
        })
        .transpose()?;
    let quest = quest
        .map(|q| q.named(&file.stimulus, &factors, &levels_of, e))
        .transpose()?;
    let adjustment = file
        .adjustment
        .map(|a| {
            let span = a.span();
            let a = a.into_inner();
            let given = [&a.stronger, &a.weaker, &a.same];
            let labels = given.map(|l| l.get_ref().0.as_str());
            if let Some((i, j)) = repeated(&labels) {
                let names = ["stronger", "weaker", "same"];
                // A default label is on no line: name the table's.
                let at = Some(given[j].span()).filter(|s| !s.is_empty());
                return Err(e.at(
                    at.unwrap_or(span),
                    names[j],
                    format!(
                        "`{}` and `{}` ({}) are the same answer: the three must differ, also in case",
                        labels[j], labels[i], names[i]
                    ),
                ));
            }
            let (min_mm, max_mm, start) = (a.min_mm.0, a.max_mm.0, a.start_mm.get_ref().0);
            if !(min_mm <= start && start <= max_mm) {
                return Err(e.at(
                    a.start_mm.span(),
                    "start_mm",
                    "give min_mm <= start_mm <= max_mm (max_mm defaults to 100)",
                ));
            }
            Ok(Adjustment {
                text: a.text.0,
                start_mm: start,
                step_mm: a.step_mm.0,
                max: a.max.0,
                min_mm,
                max_mm,
                stronger: a.stronger.into_inner().0,
                weaker: a.weaker.into_inner().0,
                same: a.same.into_inner().0,
            })
        })
        .transpose()?;
    let order = Order::from(file.order);
    let blocks = super::blocks::check(file.block, &factors, &conditions, sets, order, e)?;
    let block_names: Vec<String> = blocks.iter().map(|b| b.name.clone()).collect();
    let columns = Columns::new(
        factors
            .iter()
            .map(|f| Column::new(&f.name, Holds::Level(f.levels.clone())))
            .collect(),
        questions.iter().flat_map(Question::column_list).collect(),
        adjustment
            .as_ref()
            .map(|a| AdjustColumns {
                min_mm: a.min_mm,
                max_mm: a.max_mm,
                max: a.max,
                labels: a.labels(),
            })
            .as_ref(),
    )
    .and_then(|c| {
        // Where its threshold lies: a staircase averages its levels,
        // QUEST+ takes its candidate thresholds' posterior mean.
        let range = |v: &[f64]| {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            (lo, v.iter().copied().fold(lo, f64::max))
        };
        let adaptive = match (&staircase, &quest) {
            (Some(s), _) => Some((Adaptive::Staircase, &s.grid, range(&s.grid.values))),
            (_, Some(q)) => Some((Adaptive::Quest, &q.grid, range(&q.model().thresholds))),
            (None, None) => None,
        };
        match adaptive {
            Some((kind, g, at)) => {
                c.with_adaptive(kind, g.labels.clone(), g.answers(), g.trials, at)
            }
            None => Ok(c),
        }
    })
    .and_then(|c| {
        if block_names.is_empty() {
            Ok(c)
        } else {
            c.with_blocks(block_names)
        }
    })
    .map_err(|m| e.bad(m))?;
    Ok(Unlinked {
        name: file.name.0,
        library: file.library,
        stimulus: file.stimulus,
        sets,
        order,
        blocks,
        timeline,
        factors,
        conditions,
        questions,
        adjustment,
        staircase,
        quest,
        columns,
        report,
    })
}

fn timeline(file: &File, e: &Errors) -> Result<Timeline, InputError> {
    let span = file.timeline.span();
    let t = file.timeline.get_ref();
    // A procedure's trial repeats its on/off phases until answered.
    let procedure = match (&file.adjustment, &file.staircase, &file.quest) {
        (Some(_), _, _) => Some("[adjustment]"),
        (None, Some(_), _) => Some("[staircase]"),
        (None, None, Some(_)) => Some("[quest]"),
        (None, None, None) => None,
    };
    let on_s = t.on_s.as_ref().map(|s| s.get_ref().0);
    let while_touching = t.while_touching.as_ref().is_some_and(|w| *w.get_ref());
    if on_s.is_none() && !while_touching {
        return Err(e.at(
            span,
            "on_s",
            "give `on_s` or `while_touching = true` in [timeline]",
        ));
    }
    if let Some(w) = t
        .while_touching
        .as_ref()
        .filter(|_| while_touching && !t.wait_for_finger)
    {
        return Err(e.at(
            w.span(),
            "while_touching",
            "needs `wait_for_finger = true` (it ends when the finger leaves)",
        ));
    }
    let repeat = match &t.repeat {
        None => 1,
        Some(r) => {
            let max = crate::lab::session::MAX_REPEAT;
            let n = r.get_ref().get();
            if !(1..=max).contains(&n) {
                return Err(e.at(
                    r.span(),
                    "repeat",
                    format!("{n} is out of range: allowed 1..={max}"),
                ));
            }
            if let Some(what) = procedure {
                return Err(e.at(
                    r.span(),
                    "repeat",
                    format!("an {what} trial repeats its on/off phases until answered: give `on_s` and no `repeat`"),
                ));
            }
            if on_s.is_none() {
                return Err(e.at(r.span(), "repeat", "needs `on_s`"));
            }
            n
        }
    };
    if let Some(off) = &t.off_s {
        crate::lab::session::check_off_s(true, repeat, procedure.is_some())
            .map_err(|m| e.at(off.span(), "off_s", m))?;
    }
    if let Some(what) = procedure.filter(|_| on_s.is_none()) {
        return Err(e.at(
            span,
            "on_s",
            format!("an {what} trial repeats its on/off phases until answered: give `on_s`"),
        ));
    }
    Ok(Timeline {
        wait_for_finger: t.wait_for_finger,
        on_s,
        while_touching,
        off_s: t.off_s.as_ref().map_or(0.0, |s| s.get_ref().0),
        repeat,
        iti_s: t.iti_s.0,
        gate: t.gate,
        touch_s: t.touch_s.map_or(super::file::DEFAULT_TOUCH_S, |s| s.0),
    })
}

fn factors(file: &File, e: &Errors) -> Result<Vec<Factor>, InputError> {
    if file.factor.is_empty() {
        return Err(e.bad("no factors: add at least one [[factor]] with `name` and `levels`"));
    }
    let mut out: Vec<Factor> = Vec::new();
    for f in &file.factor {
        let name = e.unique("factor", &f.name, out.iter().map(|x| x.name.as_str()))?;
        let levels: Vec<String> = f.levels.get_ref().iter().map(|l| l.0.clone()).collect();
        if levels.is_empty() {
            return Err(e.at(
                f.levels.span(),
                "levels",
                format!("factor `{name}` has no levels"),
            ));
        }
        if let Some(i) = (1..levels.len()).find(|&i| levels[..i].contains(&levels[i])) {
            return Err(e.at(
                f.levels.span(),
                "levels",
                format!("factor `{name}`: level `{}` is given twice", levels[i]),
            ));
        }
        out.push(Factor { name, levels });
    }
    Ok(out)
}

/// The factors' product, first factor slowest; the count checked before
/// anything is allocated (64 factors of two levels would wrap to 0).
fn conditions(
    template: &Spanned<String>,
    factors: &[Factor],
    level: Option<&str>,
    e: &Errors,
) -> Result<Vec<Condition>, InputError> {
    let n = factors
        .iter()
        .try_fold(1usize, |n, f| n.checked_mul(f.levels.len()))
        .filter(|n| (1..=MAX_CONDITIONS).contains(n))
        .ok_or_else(|| {
            let product: f64 = factors.iter().map(|f| f.levels.len() as f64).product();
            e.bad(format!(
                "{} factors give {} conditions; a protocol has 1 to {MAX_CONDITIONS}",
                factors.len(),
                crate::limits::show(product)
            ))
        })?;
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let mut rest = k;
        let mut levels = vec![String::new(); factors.len()];
        for (i, f) in factors.iter().enumerate().rev() {
            levels[i] = f.levels[rest % f.levels.len()].clone();
            rest /= f.levels.len();
        }
        let stimulus = super::expand_level(template.get_ref(), factors, &levels, level)
            .map_err(|m| e.at(template.span(), "stimulus", m))?;
        if let Err(m) = crate::plan::library::check_id(&stimulus) {
            return Err(e.at(
                template.span(),
                "stimulus",
                format!("condition {}: {m}", levels.join("/")),
            ));
        }
        out.push(Condition { levels, stimulus });
    }
    Ok(out)
}

fn question(q: QuestionFile, e: &Errors) -> Result<Question, InputError> {
    let id = q.id.get_ref().0.clone();
    let qbad = |span: Range<usize>, field: &str, m: String| {
        e.at(span, field, format!("question `{id}`: {m}"))
    };
    let kind_name = match q.kind {
        KindFile::Likert => "likert",
        KindFile::Choice => "choice",
        KindFile::Number => "number",
    };
    let only = |field: &str, span: Option<Range<usize>>, applies: bool| match span {
        Some(s) if !applies => Err(qbad(
            s,
            field,
            format!("`{field}` does not apply to a {kind_name} question"),
        )),
        _ => Ok(()),
    };
    let (likert, choice, number) = (
        matches!(q.kind, KindFile::Likert),
        matches!(q.kind, KindFile::Choice),
        matches!(q.kind, KindFile::Number),
    );
    only("points", q.points.as_ref().map(Spanned::span), likert)?;
    only("low", q.low.as_ref().map(Spanned::span), likert)?;
    only("high", q.high.as_ref().map(Spanned::span), likert)?;
    only("items", q.items.as_ref().map(Spanned::span), likert)?;
    only("options", q.options.as_ref().map(Spanned::span), choice)?;
    only("min", q.min.as_ref().map(Spanned::span), number)?;
    only("max", q.max.as_ref().map(Spanned::span), number)?;
    let shuffle = q.shuffle.as_ref().is_some_and(|s| *s.get_ref());
    if let Some(s) = q.shuffle.as_ref().filter(|_| shuffle) {
        only("shuffle", Some(s.span()), !number)?;
    }
    // Items and options: 2 to MAX_OPTIONS, told apart as answers are.
    let list = |field: &str, span: Range<usize>, v: Vec<String>| {
        if v.len() < 2 || v.len() > MAX_OPTIONS {
            return Err(qbad(
                span,
                field,
                format!("give 2 to {MAX_OPTIONS} {field}"),
            ));
        }
        let refs: Vec<&str> = v.iter().map(String::as_str).collect();
        if let Some((i, j)) = repeated(&refs) {
            return Err(qbad(
                span,
                field,
                format!(
                    "`{}` and `{}` are the same answer: give each once, also in case",
                    v[j], v[i]
                ),
            ));
        }
        Ok(v)
    };
    let kind = match q.kind {
        KindFile::Likert => {
            // Any number the file wrote, judged by the scale's range.
            let points = match &q.points {
                None => super::file::DEFAULT_POINTS,
                Some(p) => match p.get_ref().whole_in(2, MAX_OPTIONS as u64) {
                    Ok(v) => v as u32,
                    Err(m) => return Err(qbad(p.span(), "points", m)),
                },
            };
            let items = match q.items {
                Some(i) => {
                    let span = i.span();
                    list(
                        "items",
                        span,
                        i.into_inner().into_iter().map(|n| n.0).collect(),
                    )?
                }
                None => Vec::new(),
            };
            if let Some(s) = q.shuffle.as_ref().filter(|_| shuffle && items.is_empty()) {
                return Err(qbad(
                    s.span(),
                    "shuffle",
                    "a likert question shuffles its `items`; give them".into(),
                ));
            }
            Kind::Likert {
                points,
                low: q.low.map(|l| l.into_inner().0).unwrap_or_default(),
                high: q.high.map(|l| l.into_inner().0).unwrap_or_default(),
                items,
            }
        }
        KindFile::Choice => {
            let Some(o) = q.options else {
                return Err(qbad(
                    q.id.span(),
                    "options",
                    format!("give 2 to {MAX_OPTIONS} options"),
                ));
            };
            let span = o.span();
            Kind::Choice {
                options: list(
                    "options",
                    span,
                    o.into_inner().into_iter().map(|l| l.0).collect(),
                )?,
            }
        }
        KindFile::Number => {
            let lim = super::MAX_NUMBER;
            let min = q.min.as_ref().map_or(-lim, |m| m.get_ref().0);
            let max = q.max.as_ref().map_or(lim, |m| m.get_ref().0);
            if min > max {
                let span = q.max.as_ref().map_or(q.id.span(), Spanned::span);
                return Err(qbad(span, "max", "give `min` <= `max`".into()));
            }
            Kind::Number { min, max }
        }
    };
    // `na` is what the participant types for it, so an option may not
    // be `na` too.
    if q.not_perceived.is_some()
        && let Kind::Choice { options } = &kind
        && let Some(o) = options
            .iter()
            .find(|o| o.eq_ignore_ascii_case(crate::lab::study::columns::NOT_PERCEIVED))
    {
        let span = q.not_perceived.as_ref().map_or(q.id.span(), Spanned::span);
        return Err(qbad(
            span,
            "not_perceived",
            format!("option `{o}` is what \"not perceived\" is typed as: rename the option"),
        ));
    }
    Ok(Question {
        id,
        text: q.text.0,
        kind,
        shuffle,
        not_perceived: q.not_perceived.map(|l| l.into_inner().0),
    })
}

/// The `[report]` table's tests for `factors` (see [`super::report`]);
/// `None`: the defaults.
fn report(r: Option<ReportFile>, factors: &[Factor], e: &Errors) -> Result<ReportSpec, InputError> {
    let wide = |f: &Factor| f.levels.len() >= 3;
    let Some(r) = r else {
        return Ok(ReportSpec {
            alpha: super::file::DEFAULT_ALPHA,
            repeats: Repeats::Mean,
            pairs: Vec::new(),
            friedman: factors
                .iter()
                .filter(|f| wide(f))
                .map(|f| f.name.clone())
                .collect(),
        });
    };
    let alpha = match &r.alpha {
        Some(a) if !(*a.get_ref() > 0.0 && *a.get_ref() < 1.0) => {
            return Err(e.at(
                a.span(),
                "alpha",
                format!(
                    "{} is not a significance level: give a number between 0 and 1",
                    crate::limits::show(*a.get_ref())
                ),
            ));
        }
        Some(a) => *a.get_ref(),
        None => super::file::DEFAULT_ALPHA,
    };
    let factor = |n: &str, span: std::ops::Range<usize>, field: &str| {
        factors.iter().find(|f| f.name == n).ok_or_else(|| {
            e.at(
                span,
                field,
                format!(
                    "`{n}` is not a factor (the factors: {})",
                    crate::error::some_of(factors.iter().map(|f| f.name.as_str()), ", ")
                ),
            )
        })
    };
    let mut friedman = Vec::new();
    match &r.friedman {
        Some(list) => {
            for n in list.get_ref() {
                let f = factor(&n.0, list.span(), "friedman")?;
                if !wide(f) {
                    return Err(e.at(
                        list.span(),
                        "friedman",
                        format!(
                            "factor `{}` has {} levels; a Friedman test compares at least 3",
                            f.name,
                            f.levels.len()
                        ),
                    ));
                }
                friedman.push(f.name.clone());
            }
        }
        None => friedman.extend(factors.iter().filter(|f| wide(f)).map(|f| f.name.clone())),
    }
    let mut pairs = Vec::new();
    for p in &r.pairs {
        let f = factor(&p.factor.get_ref().0, p.factor.span(), "factor")?;
        let list = match &p.pairs {
            None => crate::lab::stats::table::all_pairs(
                &f.levels.iter().map(String::as_str).collect::<Vec<_>>(),
            ),
            Some(given) => {
                let mut v = Vec::new();
                for (a, b) in given.get_ref() {
                    for l in [&a.0, &b.0] {
                        if !f.levels.contains(l) {
                            return Err(e.at(
                                given.span(),
                                "pairs",
                                format!(
                                    "`{}` is not a level of factor `{}` ({})",
                                    l.escape_debug(),
                                    f.name,
                                    crate::error::some_of(&f.levels, ", ")
                                ),
                            ));
                        }
                    }
                    if a.0 == b.0 {
                        return Err(e.at(
                            given.span(),
                            "pairs",
                            format!("`{}` is paired with itself", a.0),
                        ));
                    }
                    v.push((a.0.clone(), b.0.clone()));
                }
                v
            }
        };
        if list.is_empty() {
            return Err(e.at(
                p.factor.span(),
                "factor",
                format!("factor `{}` has one level: nothing to pair", f.name),
            ));
        }
        pairs.push(PairSpec {
            factor: f.name.clone(),
            pairs: list,
        });
    }
    Ok(ReportSpec {
        alpha,
        repeats: match r.repeats {
            RepeatsFile::Mean => Repeats::Mean,
            RepeatsFile::Median => Repeats::Median,
        },
        pairs,
        friedman,
    })
}

impl From<OrderFile> for Order {
    fn from(o: OrderFile) -> Self {
        match o {
            OrderFile::Random => Order::Random,
            OrderFile::Sequential => Order::Sequential,
            OrderFile::FullRandom => Order::FullRandom,
            OrderFile::LatinSquare => Order::LatinSquare,
        }
    }
}
