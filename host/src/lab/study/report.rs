//! `lmhost study report`: per condition and question, n, median and
//! quartiles over every participant's `trials.csv` (`summary.csv`), the
//! choices' counts (`choices.csv`), and a box plot per numeric question
//! (PNG and SVG). Every file is written whole.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::design;
use super::protocol::Unlinked;
use super::record::{self, Expect, SessionFile, Tail};
use crate::error::InputError;

/// Quantile `q` of sorted `v` (the one definition, [`crate::clock::quantile`]).
pub use crate::clock::quantile;

/// One condition's numbers for one question.
#[derive(Debug, Clone, PartialEq)]
pub struct Stat {
    /// The stimulus.
    pub stimulus: String,
    /// Factor levels.
    pub levels: Vec<String>,
    /// The question column.
    pub question: String,
    /// The values, sorted.
    pub values: Vec<f64>,
    /// "Not perceived" answers (left out of `values`).
    pub not_perceived: usize,
}

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
        let why: Vec<String> = skipped
            .iter()
            .map(|(d, w)| format!("{}: {w}", d.display()))
            .collect();
        return Err(InputError::new(format!(
            "{}: no participant folder in it (one holds session.json and trials.csv; give a participant folder or the study's --out){}",
            dir.display(),
            if why.is_empty() {
                String::new()
            } else {
                format!("; skipped {}", why.join("; "))
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
    let plan = design::plan_of(
        protocol.sets,
        &protocol.conditions,
        &protocol.questions,
        protocol.order,
        session.seed,
        session.index,
    );
    if plan != session.trials {
        crate::bad_input!(
            "{}: its trial order does not follow from its seed",
            sp.display()
        );
    }
    let expect = Expect {
        participant: &session.participant,
        factors: &protocol.factors,
        conditions: &protocol.conditions,
        questions: &protocol.questions,
    };
    let trials = record::read_trials(&d.join("trials.csv"), &protocol.columns, &plan, &expect)?;
    Ok(Participant {
        session,
        protocol,
        plan,
        trials,
    })
}

/// Reads every participant under `dir` and writes the summary and figures
/// into `dir`. Every value summarised is one its column accepts (a Likert
/// point on its scale, a number in its range, finite).
pub fn report(dir: &Path) -> anyhow::Result<Report> {
    let (dirs, skipped) = participant_dirs(dir)?;
    let mut first: Option<Participant> = None;
    // (condition, stimulus, row) of every participant.
    let mut rows: Vec<(usize, Vec<String>)> = Vec::new();
    let mut out = Report {
        participants: dirs.len(),
        skipped,
        ..Report::default()
    };
    for d in &dirs {
        let p = read_participant(d)?;
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
        rows.extend(
            p.trials
                .rows
                .iter()
                .zip(&p.plan)
                .map(|(r, t)| (t.condition, r.clone())),
        );
        first.get_or_insert(p);
    }
    let Some(first) = first else {
        crate::bad_input!("{}: nothing to report", dir.display());
    };
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
    figures(dir, &stats, &mut out.files)?;
    Ok(out)
}

/// A box plot per numeric question: PNG, SVG and PDF.
fn figures(dir: &Path, stats: &[Stat], files: &mut Vec<PathBuf>) -> anyhow::Result<()> {
    crate::field::plot::register_font();
    let mut questions: Vec<&str> = Vec::new();
    for st in stats {
        if !questions.contains(&st.question.as_str()) {
            questions.push(&st.question);
        }
    }
    for q in questions {
        let group: Vec<&Stat> = stats.iter().filter(|s| s.question == q).collect();
        let size = ((90 * group.len() as u32).max(400) + 100, 520);
        let png = dir.join(format!("box-{q}.png"));
        let e = |x: String| anyhow::anyhow!("drawing {}: {x}", png.display());
        crate::field::plot::write_png(&png, size, |root| {
            draw(root, q, &group).map_err(e)?;
            Ok(())
        })?;
        files.push(png);
        let svg_path = dir.join(format!("box-{q}.svg"));
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
            draw(&root, q, &group)
                .map_err(|x| anyhow::anyhow!("drawing {}: {x}", svg_path.display()))?;
            root.present()
                .map_err(|x| anyhow::anyhow!("drawing {}: {x}", svg_path.display()))?;
        }
        crate::files::write_whole(&svg_path, svg.as_bytes())?;
        files.push(svg_path);
        // The PDF at the SVG's 96 units per inch.
        let pdf_path = dir.join(format!("box-{q}.pdf"));
        let e = |x: String| anyhow::anyhow!("drawing {}: {x}", pdf_path.display());
        let mut pdf = Vec::new();
        {
            let backend =
                crate::pdf::PdfBackend::new(&mut pdf, size, 0.75, crate::field::plot::FONT)
                    .map_err(|x| e(x.to_string()))?;
            let root = backend.into_drawing_area();
            draw(&root, q, &group).map_err(e)?;
            root.present().map_err(|x| e(x.to_string()))?;
        }
        crate::files::write_whole(&pdf_path, &pdf)?;
        files.push(pdf_path);
    }
    Ok(())
}

/// One box per condition: quartile box, median line, whiskers to the most
/// extreme values within 1.5 IQR, points beyond.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    question: &str,
    group: &[&Stat],
) -> Result<(), String> {
    let s = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(s)?;
    let all = group.iter().flat_map(|g| g.values.iter().copied());
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    // The values are checked finite and in range; a span that overflows
    // would have the axis' ticks loop forever, so it is refused too.
    let pad = ((hi - lo) * 0.08).max(0.5);
    if !(lo - pad).is_finite() || !(hi + pad).is_finite() {
        return Err(format!(
            "the values span {} to {}, too wide to draw",
            crate::limits::show(lo),
            crate::limits::show(hi)
        ));
    }
    let n = group.len();
    let names: Vec<String> = group.iter().map(|g| g.stimulus.clone()).collect();
    let mut chart = ChartBuilder::on(root)
        .caption(question, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(60)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..n as f64, (lo - pad)..(hi + pad))
        .map_err(s)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_max_light_lines(1)
        .y_desc(question)
        .draw()
        .map_err(s)?;
    let blue = RGBColor(44, 113, 142);
    for (i, g) in group.iter().enumerate() {
        if g.values.is_empty() {
            continue;
        }
        let x = i as f64 + 0.5;
        let (q1, med, q3) = (
            quantile(&g.values, 0.25),
            quantile(&g.values, 0.5),
            quantile(&g.values, 0.75),
        );
        let iqr = q3 - q1;
        let wlo = g
            .values
            .iter()
            .copied()
            .find(|v| *v >= q1 - 1.5 * iqr)
            .unwrap_or(q1);
        let whi = g
            .values
            .iter()
            .rev()
            .copied()
            .find(|v| *v <= q3 + 1.5 * iqr)
            .unwrap_or(q3);
        let w = 0.3;
        chart
            .draw_series([
                Rectangle::new([(x - w, q1), (x + w, q3)], blue.mix(0.3).filled()),
                Rectangle::new([(x - w, q1), (x + w, q3)], blue.stroke_width(1)),
            ])
            .map_err(s)?;
        chart
            .draw_series([
                PathElement::new(vec![(x - w, med), (x + w, med)], BLACK.stroke_width(2)),
                PathElement::new(vec![(x, q3), (x, whi)], blue.stroke_width(1)),
                PathElement::new(vec![(x, q1), (x, wlo)], blue.stroke_width(1)),
                PathElement::new(
                    vec![(x - w / 2.0, whi), (x + w / 2.0, whi)],
                    blue.stroke_width(1),
                ),
                PathElement::new(
                    vec![(x - w / 2.0, wlo), (x + w / 2.0, wlo)],
                    blue.stroke_width(1),
                ),
            ])
            .map_err(s)?;
        chart
            .draw_series(
                g.values
                    .iter()
                    .filter(|v| **v < wlo || **v > whi)
                    .map(|v| Circle::new((x, *v), 3, RED.filled())),
            )
            .map_err(s)?;
    }
    // Condition names under their boxes (the axis' own ticks fall
    // between them).
    let style = TextStyle::from(("sans-serif", 12).into_font()).pos(
        plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Top,
        ),
    );
    for (i, name) in names.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, lo - pad));
        root.draw(&Text::new(name.clone(), (px, py + 8), style.clone()))
            .map_err(s)?;
    }
    Ok(())
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
