//! `lmhost study report`: per condition and question, n, median and
//! quartiles over every participant's `trials.csv` (`summary.csv`), the
//! choices' counts (`choices.csv`), and a box plot per numeric question
//! (PNG and SVG). Every file is written whole.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::record::{self, SessionFile};
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
}

/// What the report wrote.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Participants read.
    pub participants: usize,
    /// Trial rows read.
    pub rows: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
}

fn participant_dirs(dir: &Path) -> Result<Vec<PathBuf>, InputError> {
    if dir.join("trials.csv").is_file() {
        return Ok(vec![dir.to_owned()]);
    }
    let rd = std::fs::read_dir(dir)
        .map_err(|e| InputError::new(format!("{}: {}", dir.display(), crate::files::reason(&e))))?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.join("trials.csv").is_file() && p.join("session.json").is_file())
        .collect();
    v.sort();
    if v.is_empty() {
        return Err(InputError::new(format!(
            "{}: no trials.csv in it or in its folders (give a participant folder or the study's --out)",
            dir.display()
        )));
    }
    Ok(v)
}

/// Reads every participant under `dir` and writes the summary and figures
/// into `dir`.
pub fn report(dir: &Path) -> anyhow::Result<Report> {
    let dirs = participant_dirs(dir)?;
    let mut protocol: Option<SessionFile> = None;
    let mut header: Option<Vec<String>> = None;
    let mut rows: Vec<Vec<String>> = Vec::new();
    for d in &dirs {
        let sp = d.join("session.json");
        let text = std::fs::read_to_string(&sp).map_err(|e| {
            InputError::new(format!("{}: {}", sp.display(), crate::files::reason(&e)))
        })?;
        let s: SessionFile = serde_json::from_str(&text)
            .map_err(|e| InputError::new(format!("{}: {e}", sp.display())))?;
        if let Some(p) = &protocol
            && p.protocol != s.protocol
        {
            crate::bad_input!(
                "{}: another protocol (`{}`) than {} (`{}`): report one protocol at a time",
                sp.display(),
                s.protocol_name,
                dirs[0].display(),
                p.protocol_name
            );
        }
        protocol.get_or_insert(s);
        let tp = d.join("trials.csv");
        let text = std::fs::read_to_string(&tp).map_err(|e| {
            InputError::new(format!("{}: {}", tp.display(), crate::files::reason(&e)))
        })?;
        let mut lines = text.lines();
        let h = record::split(lines.next().unwrap_or_default())
            .map_err(|m| InputError::new(format!("{}: {m}", tp.display())))?;
        if header.as_ref().is_some_and(|x| *x != h) {
            crate::bad_input!("{}: its columns differ from the others'", tp.display());
        }
        for (i, l) in lines.enumerate() {
            let r = record::split(l)
                .map_err(|m| InputError::new(format!("{} line {}: {m}", tp.display(), i + 2)))?;
            if r.len() != h.len() {
                crate::bad_input!(
                    "{} line {}: {} fields, the header has {}",
                    tp.display(),
                    i + 2,
                    r.len(),
                    h.len()
                );
            }
            rows.push(r);
        }
        header.get_or_insert(h);
    }
    let (Some(s), Some(h)) = (protocol, header) else {
        crate::bad_input!("{}: nothing to report", dir.display());
    };
    let col = |name: &str| h.iter().position(|x| x == name);
    let stim =
        col("stimulus").ok_or_else(|| InputError::new("trials.csv has no stimulus column"))?;
    let factors: Vec<usize> = s
        .columns
        .iter()
        .filter(|(_, k)| k == "factor")
        .filter_map(|(n, _)| col(n))
        .collect();
    // Conditions in the protocol's order.
    let mut order: BTreeMap<String, usize> = BTreeMap::new();
    for t in &s.trials {
        order.entry(t.stimulus.clone()).or_insert(t.condition);
    }
    let mut stats: Vec<Stat> = Vec::new();
    let mut choices: BTreeMap<(usize, String, String, String), usize> = BTreeMap::new();
    for (name, kind) in &s.columns {
        if kind == "factor" {
            continue;
        }
        let Some(c) = col(name) else { continue };
        let mut by: BTreeMap<(usize, String), (Vec<String>, Vec<f64>)> = BTreeMap::new();
        for r in &rows {
            let key = (
                order.get(&r[stim]).copied().unwrap_or(usize::MAX),
                r[stim].clone(),
            );
            let levels = factors.iter().map(|&i| r[i].clone()).collect();
            let e = by.entry(key.clone()).or_insert((levels, Vec::new()));
            if r[c].is_empty() {
                continue;
            }
            if kind == "choice" {
                *choices
                    .entry((key.0, key.1, name.clone(), r[c].clone()))
                    .or_default() += 1;
            } else if let Ok(v) = r[c].parse::<f64>() {
                e.1.push(v);
            }
        }
        if kind == "choice" {
            continue;
        }
        for ((_, stimulus), (levels, mut values)) in by {
            values.sort_by(f64::total_cmp);
            stats.push(Stat {
                stimulus,
                levels,
                question: name.clone(),
                values,
            });
        }
    }
    let factor_names: Vec<String> = factors.iter().map(|&i| h[i].clone()).collect();
    let mut out = Report {
        participants: dirs.len(),
        rows: rows.len(),
        files: Vec::new(),
    };
    let mut csv = String::new();
    let mut head = vec!["stimulus".to_owned()];
    head.extend(factor_names.iter().cloned());
    head.extend(["question", "n", "median", "q1", "q3", "iqr"].map(String::from));
    csv.push_str(&record::line(&head));
    csv.push('\n');
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
            num(quantile(&st.values, 0.5)),
            num(q1),
            num(q3),
            num(q3 - q1),
        ]);
        csv.push_str(&record::line(&f));
        csv.push('\n');
    }
    let p = dir.join("summary.csv");
    crate::files::write_whole(&p, csv.as_bytes())?;
    out.files.push(p);
    if !choices.is_empty() {
        let mut csv = String::from("stimulus,question,option,count\n");
        for ((_, stimulus, q, o), n) in &choices {
            csv.push_str(&record::line(&[
                stimulus.clone(),
                q.clone(),
                o.clone(),
                n.to_string(),
            ]));
            csv.push('\n');
        }
        let p = dir.join("choices.csv");
        crate::files::write_whole(&p, csv.as_bytes())?;
        out.files.push(p);
    }
    crate::field::plot::register_font();
    let mut questions: Vec<&str> = Vec::new();
    for st in &stats {
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
        out.files.push(png);
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
        out.files.push(svg_path);
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
        out.files.push(pdf_path);
    }
    Ok(out)
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
    let pad = ((hi - lo) * 0.08).max(0.5);
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
