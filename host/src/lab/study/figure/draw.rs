//! A box figure's layout in backend units ([`UNITS_PER_PT`] per point)
//! and its drawing onto any plotters backend. Bands from the top: the
//! question (wrapped), the scale's end labels, the legend, the marks, the
//! plot, n per box, the group labels and the x axis' name.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::BoxFigure;
use crate::clock::quantile;
use crate::field::plot::{LABEL_PT, TICK_PT, UNITS_PER_PT};

fn pt(v: f64) -> i32 {
    (v * UNITS_PER_PT).round() as i32
}

/// The series' colours (Okabe and Ito's, told apart in colour-blind
/// vision and in grey).
const COLOURS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(213, 94, 0),
    RGBColor(240, 228, 66),
];

fn colour(series: usize) -> RGBColor {
    COLOURS[series % COLOURS.len()]
}

/// Width and height (units) of `text` at `size_pt`, as the bitmap backend
/// draws it (the SVG and PDF scale their fonts to the same em).
fn measure(text: &str, size_pt: f64) -> Result<(i32, i32), String> {
    if text.is_empty() {
        return Ok((0, 0));
    }
    let (w, h) = ("sans-serif", size_pt * UNITS_PER_PT)
        .into_font()
        .box_size(text)
        .map_err(|e| format!("measuring text: {e:?}"))?;
    Ok((w as i32, h as i32))
}

/// `text` in lines no wider than `width` units at `size_pt`.
fn wrap(text: &str, size_pt: f64, width: i32) -> Result<Vec<String>, String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let next = if line.is_empty() {
            word.to_owned()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && measure(&next, size_pt)?.0 > width {
            lines.push(std::mem::replace(&mut line, word.to_owned()));
        } else {
            line = next;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    Ok(lines)
}

/// Where everything goes, in backend units.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Font size per point (plotters' SVG backend writes size / 1.24).
    font_k: f64,
    /// The page.
    pub size: (u32, u32),
    title: Vec<String>,
    subtitle: Vec<String>,
    /// The legend's rows of series.
    legend: Vec<Vec<usize>>,
    legend_y: i32,
    /// Each mark's level above the plot (0 nearest).
    levels: Vec<usize>,
    /// The plot's frame.
    left: i32,
    top: i32,
    width: i32,
    height: i32,
    /// Each box's centre x.
    pub box_x: Vec<i32>,
    box_w: i32,
}

const LINE: f64 = 1.25;
const LEVEL_PT: f64 = TICK_PT * 1.3 + 2.5;

impl Layout {
    /// The layout of `b` on a page `width_mm` wide.
    pub fn new(b: &BoxFigure, width_mm: f64) -> Result<Self, String> {
        let w = (width_mm / 25.4 * 72.0 * UNITS_PER_PT).round() as i32;
        let pad = pt(3.0);
        let text_w = w - 2 * pad;
        let title = wrap(&b.title, LABEL_PT, text_w)?;
        let subtitle = wrap(&b.subtitle, TICK_PT, text_w)?;
        let mut y = pad + pt(LABEL_PT * LINE) * title.len() as i32;
        y += pt(TICK_PT * LINE) * subtitle.len() as i32;
        if !title.is_empty() || !subtitle.is_empty() {
            y += pt(LABEL_PT * 0.4);
        }
        // Legend rows: swatch, label, space, as many as fit a line.
        let mut legend: Vec<Vec<usize>> = Vec::new();
        let mut x = 0;
        for (i, s) in b.series.iter().enumerate() {
            let item = pt(LABEL_PT * 1.3) + measure(s, LABEL_PT)?.0 + pt(LABEL_PT * 1.5);
            match legend.last_mut() {
                Some(row) if x + item <= text_w => row.push(i),
                _ => {
                    legend.push(vec![i]);
                    x = 0;
                }
            }
            x += item;
        }
        if b.series.len() < 2 {
            legend.clear();
        }
        let legend_y = y;
        y += pt(LABEL_PT * 1.6) * legend.len() as i32;
        // The y axis: its name (rotated), then the widest tick label.
        let tick = |v: f64| crate::limits::show(v);
        let mut tick_w = measure("n", TICK_PT)?.0;
        for t in &b.ticks {
            tick_w = tick_w.max(measure(&tick(*t), TICK_PT)?.0);
        }
        let left = pad + pt(LABEL_PT * 1.5) + tick_w + pt(3.5);
        let width = w - left - pad;
        let groups = b.groups.len().max(1) as i32;
        let series = b.series.len().max(1) as f64;
        let slot = width as f64 / groups as f64;
        let box_slot = slot * 0.84 / series;
        let box_x = b
            .boxes
            .iter()
            .map(|x| {
                left + (slot * (x.group as f64 + 0.08) + box_slot * (x.series as f64 + 0.5)).round()
                    as i32
            })
            .collect::<Vec<_>>();
        let box_w = ((box_slot * 0.7).round() as i32).max(pt(1.0));
        // Marks: the shortest spans first, each on the lowest level where
        // neither its bracket nor its text meets another's.
        let mut order: Vec<usize> = (0..b.marks.len()).collect();
        let span = |i: usize| -> Result<(i32, i32), String> {
            let m = &b.marks[i];
            let (xa, xb) = (box_x[m.a].min(box_x[m.b]), box_x[m.a].max(box_x[m.b]));
            let tw = measure(&m.text, TICK_PT)?.0;
            let c = (xa + xb) / 2;
            Ok((xa.min(c - tw / 2), xb.max(c + tw / 2)))
        };
        let mut spans = Vec::new();
        for i in 0..b.marks.len() {
            spans.push(span(i)?);
        }
        order.sort_by_key(|&i| (spans[i].1 - spans[i].0, spans[i].0));
        let mut levels = vec![0; b.marks.len()];
        let mut placed: Vec<usize> = Vec::new();
        for i in order {
            let gap = pt(1.5);
            let mut k = 0;
            while placed.iter().any(|&j| {
                levels[j] == k && spans[j].0 < spans[i].1 + gap && spans[i].0 < spans[j].1 + gap
            }) {
                k += 1;
            }
            levels[i] = k;
            placed.push(i);
        }
        let used = levels.iter().map(|k| k + 1).max().unwrap_or(0) as i32;
        let top = y + pt(LEVEL_PT) * used + pt(TICK_PT * 0.5);
        let height = ((width as f64 * 0.6) as i32).min(pt(150.0));
        let bottom = top + height + pt(TICK_PT * 1.5) + pt(TICK_PT * 1.5) + pt(LABEL_PT * 1.6);
        Ok(Self {
            font_k: UNITS_PER_PT,
            size: (w as u32, (bottom + pad) as u32),
            title,
            subtitle,
            legend,
            legend_y,
            levels,
            left,
            top,
            width,
            height,
            box_x,
            box_w,
        })
    }

    /// The same layout with fonts of `font_k` backend units per point
    /// ([`crate::field::plot::font_k`]).
    pub fn with_font_k(&self, font_k: f64) -> Self {
        Self {
            font_k,
            ..self.clone()
        }
    }

    fn text(&self, size_pt: f64, pos: Pos) -> TextStyle<'static> {
        TextStyle::from(("sans-serif", size_pt * self.font_k).into_font())
            .color(&BLACK)
            .pos(pos)
    }
}

/// Draws `b` onto `root` as `lay` places it.
pub(super) fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    b: &BoxFigure,
) -> Result<(), String> {
    let s = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(s)?;
    let pad = pt(3.0);
    let left_top = Pos::new(HPos::Left, VPos::Top);
    let centre = Pos::new(HPos::Center, VPos::Center);
    let mut y = pad;
    for line in &lay.title {
        root.draw_text(line, &lay.text(LABEL_PT, left_top), (pad, y))
            .map_err(s)?;
        y += pt(LABEL_PT * LINE);
    }
    for line in &lay.subtitle {
        root.draw_text(line, &lay.text(TICK_PT, left_top), (pad, y))
            .map_err(s)?;
        y += pt(TICK_PT * LINE);
    }
    // The legend.
    let sw = pt(LABEL_PT);
    for (r, row) in lay.legend.iter().enumerate() {
        let cy = lay.legend_y + pt(LABEL_PT * 1.6) * r as i32 + pt(LABEL_PT * 0.8);
        let mut x = lay.left;
        for &i in row {
            root.draw(&Rectangle::new(
                [(x, cy - sw / 2), (x + sw, cy + sw / 2)],
                colour(i).filled(),
            ))
            .map_err(s)?;
            root.draw(&Rectangle::new(
                [(x, cy - sw / 2), (x + sw, cy + sw / 2)],
                BLACK.stroke_width(pt(0.25).max(1) as u32),
            ))
            .map_err(s)?;
            x += pt(LABEL_PT * 1.3);
            let style = lay.text(LABEL_PT, Pos::new(HPos::Left, VPos::Center));
            root.draw_text(&b.series[i], &style, (x, cy)).map_err(s)?;
            x += measure(&b.series[i], LABEL_PT)?.0 + pt(LABEL_PT * 1.5);
        }
    }
    // The plot's coordinates: the fixed range with a little room.
    let (lo, hi) = b.range;
    let span = if hi > lo { hi - lo } else { 1.0 };
    let (ylo, yhi) = (lo - 0.05 * span, hi + 0.05 * span);
    let ymap = |v: f64| lay.top + ((yhi - v) / (yhi - ylo) * lay.height as f64).round() as i32;
    let thin = pt(0.5).max(1) as u32;
    let hair = pt(0.25).max(1) as u32;
    root.draw(&Rectangle::new(
        [
            (lay.left, lay.top),
            (lay.left + lay.width, lay.top + lay.height),
        ],
        BLACK.stroke_width(hair),
    ))
    .map_err(s)?;
    // Y ticks, a light line at each.
    let right = Pos::new(HPos::Right, VPos::Center);
    for t in &b.ticks {
        let y = ymap(*t);
        root.draw(&PathElement::new(
            vec![(lay.left, y), (lay.left + lay.width, y)],
            RGBColor(225, 225, 225).stroke_width(hair),
        ))
        .map_err(s)?;
        root.draw(&PathElement::new(
            vec![(lay.left - pt(2.0), y), (lay.left, y)],
            BLACK.stroke_width(hair),
        ))
        .map_err(s)?;
        root.draw_text(
            &crate::limits::show(*t),
            &lay.text(TICK_PT, right),
            (lay.left - pt(3.0), y),
        )
        .map_err(s)?;
    }
    let rotated = crate::field::plot::rotated_text(LABEL_PT, lay.font_k);
    root.draw_text(
        &b.y_label,
        &rotated,
        (pad + pt(LABEL_PT * 0.6), lay.top + lay.height / 2),
    )
    .map_err(s)?;
    // Group separators and labels.
    let groups = b.groups.len().max(1);
    let slot = lay.width as f64 / groups as f64;
    let n_y = lay.top + lay.height + pt(TICK_PT * 0.8);
    let group_y = n_y + pt(TICK_PT * 1.5);
    for (g, label) in b.groups.iter().enumerate() {
        let x = lay.left + (slot * (g as f64 + 0.5)).round() as i32;
        root.draw_text(label, &lay.text(TICK_PT, centre), (x, group_y))
            .map_err(s)?;
        if g > 0 {
            let xs = lay.left + (slot * g as f64).round() as i32;
            root.draw(&PathElement::new(
                vec![
                    (xs, lay.top + lay.height - pt(2.0)),
                    (xs, lay.top + lay.height),
                ],
                BLACK.stroke_width(hair),
            ))
            .map_err(s)?;
        }
    }
    root.draw_text("n", &lay.text(TICK_PT, right), (lay.left - pt(3.0), n_y))
        .map_err(s)?;
    root.draw_text(
        &b.group_title,
        &lay.text(LABEL_PT, centre),
        (
            lay.left + lay.width / 2,
            group_y + pt(TICK_PT * 0.8 + LABEL_PT * 0.9),
        ),
    )
    .map_err(s)?;
    // The boxes: quartiles, median, whiskers to the furthest values within
    // 1.5 IQR, outliers beyond as white dots; n under each.
    for (i, bx) in b.boxes.iter().enumerate() {
        let x = lay.box_x[i];
        root.draw_text(
            &bx.values.len().to_string(),
            &lay.text(TICK_PT, centre),
            (x, n_y),
        )
        .map_err(s)?;
        let v = &bx.values;
        if v.is_empty() {
            continue;
        }
        let (q1, med, q3) = (quantile(v, 0.25), quantile(v, 0.5), quantile(v, 0.75));
        let iqr = q3 - q1;
        let wlo = v
            .iter()
            .copied()
            .find(|x| *x >= q1 - 1.5 * iqr)
            .unwrap_or(q1);
        let whi = v
            .iter()
            .rev()
            .copied()
            .find(|x| *x <= q3 + 1.5 * iqr)
            .unwrap_or(q3);
        let h = lay.box_w / 2;
        let line = BLACK.stroke_width(thin);
        root.draw(&PathElement::new(
            vec![(x, ymap(whi)), (x, ymap(wlo))],
            line,
        ))
        .map_err(s)?;
        for w in [wlo, whi] {
            root.draw(&PathElement::new(
                vec![(x - h / 2, ymap(w)), (x + h / 2, ymap(w))],
                line,
            ))
            .map_err(s)?;
        }
        let corners = [(x - h, ymap(q3)), (x + h, ymap(q1))];
        root.draw(&Rectangle::new(corners, colour(bx.series).filled()))
            .map_err(s)?;
        root.draw(&Rectangle::new(corners, line)).map_err(s)?;
        root.draw(&PathElement::new(
            vec![(x - h, ymap(med)), (x + h, ymap(med))],
            BLACK.stroke_width(pt(1.0) as u32),
        ))
        .map_err(s)?;
        for o in v.iter().filter(|x| **x < wlo || **x > whi) {
            let c = (x, ymap(*o));
            root.draw(&Circle::new(c, pt(1.3), WHITE.filled()))
                .map_err(s)?;
            root.draw(&Circle::new(c, pt(1.3), line)).map_err(s)?;
        }
    }
    // The marks: a bracket over the pair, its text above.
    let bottom = Pos::new(HPos::Center, VPos::Bottom);
    for (m, k) in b.marks.iter().zip(&lay.levels) {
        let y = lay.top - pt(TICK_PT * 0.5) - pt(LEVEL_PT) * *k as i32;
        let (xa, xb) = (lay.box_x[m.a], lay.box_x[m.b]);
        root.draw(&PathElement::new(
            vec![(xa, y + pt(2.0)), (xa, y), (xb, y), (xb, y + pt(2.0))],
            BLACK.stroke_width(thin),
        ))
        .map_err(s)?;
        root.draw_text(
            &m.text,
            &lay.text(TICK_PT, bottom),
            ((xa + xb) / 2, y - pt(0.5)),
        )
        .map_err(s)?;
    }
    Ok(())
}
