//! Drawing a figure onto any plotters backend: the layout in backend
//! units, the panels, the colour bar, the legend and the labels.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Figure, LABEL_PT, Labels, Overlay, Panel, TICK_PT, UNITS_PER_PT, viridis};
use crate::field::ObservationPlane;

mod ticks;

/// The layout in backend units.
#[derive(Clone)]
pub(super) struct Layout {
    /// Font size per point: plotters' SVG backend writes size / 1.24, its
    /// bitmap backend draws size as the em height.
    font_k: f64,
    pub(super) size: (u32, u32),
    /// Top-left of the panel grid.
    x0: i32,
    y0: i32,
    pw: i32,
    ph: i32,
    gap: i32,
    xtick_h: i32,
    legend_h: i32,
    row_w: i32,
    bar_x: i32,
}

/// The width left of the grid for the y tick labels (pt).
const YTICK_W_PT: f64 = TICK_PT * 2.6;

fn pt(v: f64) -> i32 {
    (v * UNITS_PER_PT).round() as i32
}

impl Layout {
    pub(super) fn new(
        plane: &ObservationPlane,
        labels: &Labels,
        rows: usize,
        cols: usize,
        fig: &Figure,
    ) -> Self {
        let w = (fig.width_mm / 25.4 * 72.0 * UNITS_PER_PT).round() as i32;
        let lines = labels
            .rows
            .iter()
            .map(|r| r.lines().count())
            .max()
            .unwrap_or(0);
        let row_w = if lines == 0 {
            0
        } else {
            pt(LABEL_PT * (1.25 * lines as f64 + 0.4))
        };
        let ytitle_w = pt(LABEL_PT * 1.6);
        let ytick_w = pt(YTICK_W_PT);
        let bar_w = pt(LABEL_PT * 0.8 + LABEL_PT * 1.0 + TICK_PT * 3.4 + LABEL_PT * 1.6);
        let gap = pt(LABEL_PT * 0.6);
        let legend_h = pt(LABEL_PT * 2.0);
        let col_h = if !labels.cols_title.is_empty() {
            pt(LABEL_PT * 2.9)
        } else if labels.cols.is_empty() {
            pt(LABEL_PT * 0.5)
        } else {
            pt(LABEL_PT * 1.6)
        };
        let xtick_h = pt(TICK_PT * 1.8);
        let xtitle_h = pt(LABEL_PT * 1.7);
        let x0 = row_w + ytitle_w + ytick_w;
        let c = cols as i32;
        let r = rows as i32;
        let pw = ((w - x0 - bar_w - (c - 1) * gap) / c).max(8);
        let ph = ((pw as f64 * plane.height_mm / plane.width_mm).round() as i32).max(8);
        let y0 = legend_h + col_h;
        let h = y0 + r * ph + (r - 1) * gap + xtick_h + xtitle_h;
        Self {
            font_k: UNITS_PER_PT,
            size: (w as u32, h as u32),
            x0,
            y0,
            pw,
            ph,
            gap,
            xtick_h,
            legend_h,
            row_w,
            bar_x: x0 + c * pw + (c - 1) * gap + pt(LABEL_PT * 0.8),
        }
    }

    /// Black text of `size_pt` points.
    fn text(&self, size_pt: f64) -> TextStyle<'static> {
        TextStyle::from(("sans-serif", size_pt * self.font_k).into_font()).color(&BLACK)
    }

    /// The same layout with fonts of `font_k` backend units per point
    /// ([`super::font_k`]).
    pub(super) fn with_font_k(&self, font_k: f64) -> Self {
        Self {
            font_k,
            ..self.clone()
        }
    }

    fn grid_h(&self, rows: usize) -> i32 {
        rows as i32 * self.ph + (rows as i32 - 1) * self.gap
    }
}

/// The map as an RGB image of `w × h` pixels, nearest cell, row 0 at the
/// top (largest v).
fn map_image(plane: &ObservationPlane, map: &[f64], vmax: f64, w: u32, h: u32) -> Vec<u8> {
    let (nu, nv) = (plane.nu(), plane.nv());
    let scale = if vmax > 0.0 { 1.0 / vmax } else { 0.0 };
    let mut buf = Vec::with_capacity((w * h * 3) as usize);
    for py in 0..h {
        let iv = nv - 1 - (((py as f64 + 0.5) / h as f64 * nv as f64) as usize).min(nv - 1);
        for px in 0..w {
            let iu = (((px as f64 + 0.5) / w as f64 * nu as f64) as usize).min(nu - 1);
            let c = viridis(map[iv * nu + iu] * scale);
            buf.extend_from_slice(&[c.0, c.1, c.2]);
        }
    }
    buf
}

/// The plane's extent in mm: cell edges, not centres.
fn extent(plane: &ObservationPlane) -> ((f64, f64), (f64, f64)) {
    let (nu, nv) = (plane.nu(), plane.nv());
    let h = plane.step_mm / 2.0;
    (
        (plane.u_mm(0) - h, plane.u_mm(nu - 1) + h),
        (plane.v_mm(0) - h, plane.v_mm(nv - 1) + h),
    )
}

/// Draws the panel at (`row`, `col`): the map, the overlays and a frame
/// (its ticks are [`Layout::tick_labels`]').
fn draw_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    plane: &ObservationPlane,
    panel: &Panel,
    vmax: f64,
    (row, col): (usize, usize),
) -> Result<(), String> {
    let ((u0, u1), (v0, v1)) = extent(plane);
    let x = lay.x0 + col as i32 * (lay.pw + lay.gap);
    let y = lay.y0 + row as i32 * (lay.ph + lay.gap);
    let area = root.clone().shrink((x, y), (lay.pw, lay.ph));
    let mut chart = ChartBuilder::on(&area)
        .build_cartesian_2d(u0..u1, v0..v1)
        .map_err(|e| e.to_string())?;
    let img = map_image(plane, panel.map, vmax, lay.pw as u32, lay.ph as u32);
    let elem = BitMapElement::with_owned_buffer((u0, v1), (lay.pw as u32, lay.ph as u32), img)
        .ok_or("map image of the wrong size")?;
    chart
        .draw_series(std::iter::once(elem))
        .map_err(|e| e.to_string())?;
    let o = &panel.overlay;
    let thin = pt(0.6).max(1) as u32;
    if o.orbit.len() > 1 {
        let mut path: Vec<(f64, f64)> = o.orbit.iter().map(|p| (p[0], p[1])).collect();
        path.push(path[0]);
        chart
            .draw_series(std::iter::once(PathElement::new(
                path,
                WHITE.stroke_width(thin),
            )))
            .map_err(|e| e.to_string())?;
    }
    chart
        .draw_series(
            o.foci
                .iter()
                .map(|p| Circle::new((p[0], p[1]), pt(1.6), RED.stroke_width(pt(0.7) as u32))),
        )
        .map_err(|e| e.to_string())?;
    if let Some((c, d)) = o.disk {
        // Dashed circle: every other of 72 arcs.
        let r = d / 2.0;
        let arcs = (0..72).step_by(2).map(|i| {
            let pts: Vec<(f64, f64)> = (0..=4)
                .map(|k| {
                    let a = (i as f64 + k as f64 / 4.0) * std::f64::consts::TAU / 72.0;
                    (c[0] + r * a.cos(), c[1] + r * a.sin())
                })
                .filter(|&(u, v)| u >= u0 && u <= u1 && v >= v0 && v <= v1)
                .collect();
            PathElement::new(pts, WHITE.mix(0.9).stroke_width(thin))
        });
        chart.draw_series(arcs).map_err(|e| e.to_string())?;
    }
    // The frame, drawn last so the map does not cover it.
    let frame = root.clone().shrink((x, y), (lay.pw, lay.ph));
    frame
        .draw(&Rectangle::new(
            [(0, 0), (lay.pw - 1, lay.ph - 1)],
            BLACK.stroke_width(pt(0.25).max(1) as u32),
        ))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// The colour bar right of the grid: `0..=vmax`, labelled.
fn draw_colorbar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    rows: usize,
    vmax: f64,
    label: &str,
) -> Result<(), String> {
    let top = if vmax > 0.0 { vmax } else { 1.0 };
    let bar_w = pt(LABEL_PT);
    let right = lay.size.0 as i32 - lay.bar_x - bar_w;
    let area = root
        .clone()
        .shrink((lay.bar_x, lay.y0), (bar_w + right, lay.grid_h(rows)));
    let mut chart = ChartBuilder::on(&area)
        .margin_right(pt(LABEL_PT * 0.5))
        .set_label_area_size(LabelAreaPosition::Right, right - pt(LABEL_PT * 0.5))
        .build_cartesian_2d(0.0..1.0, 0.0..top)
        .map_err(|e| e.to_string())?;
    chart
        .draw_series((0..200).map(|i| {
            let (a, b) = (top * i as f64 / 200.0, top * (i + 1) as f64 / 200.0);
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                viridis((i as f64 + 0.5) / 200.0).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(5)
        .y_desc(label)
        .y_label_formatter(&|v| format_tick(*v, top))
        .label_style(lay.text(TICK_PT))
        .axis_desc_style(lay.text(LABEL_PT))
        .set_all_tick_mark_size(pt(2.0))
        .axis_style(BLACK.stroke_width(pt(0.25).max(1) as u32))
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// The legend along the top: one swatch on the map's dark end per overlay.
fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    overlay: &Overlay,
    disk_mm: Option<f64>,
) -> Result<(), String> {
    let style = lay.text(LABEL_PT).pos(Pos::new(HPos::Left, VPos::Center));
    let sw = pt(LABEL_PT * 1.3);
    let cy = lay.legend_h / 2;
    let mut x = pt(2.0);
    let thin = pt(0.6).max(1) as u32;
    let mut items: Vec<(&str, String)> = Vec::new();
    if overlay.orbit.len() > 1 {
        items.push(("orbit", "orbit".into()));
    }
    if !overlay.foci.is_empty() {
        items.push(("foci", "foci (step 0)".into()));
    }
    if let (Some(_), Some(d)) = (overlay.disk, disk_mm) {
        items.push(("disk", format!("{} mm gauge disk", format_mm(d))));
    }
    for (kind, text) in items {
        let (l, t) = (x, cy - sw / 2);
        root.draw(&Rectangle::new(
            [(l, t), (l + sw, t + sw)],
            viridis(0.1).filled(),
        ))
        .map_err(|e| e.to_string())?;
        match kind {
            "orbit" => root.draw(&PathElement::new(
                vec![
                    (l + pt(1.5), t + sw - pt(2.5)),
                    (l + sw / 2, t + pt(2.0)),
                    (l + sw - pt(1.5), t + sw - pt(2.5)),
                ],
                WHITE.stroke_width(thin),
            )),
            "foci" => root.draw(&Circle::new(
                (l + sw / 2, cy),
                pt(1.6),
                RED.stroke_width(pt(0.7) as u32),
            )),
            _ => {
                for k in 0..3 {
                    let a = l + pt(1.0) + k * sw / 3;
                    root.draw(&PathElement::new(
                        vec![(a, cy), (a + sw / 6, cy)],
                        WHITE.stroke_width(thin),
                    ))
                    .map_err(|e| e.to_string())?;
                }
                Ok(())
            }
        }
        .map_err(|e| e.to_string())?;
        x += sw + pt(2.0);
        root.draw_text(&text, &style, (x, cy))
            .map_err(|e| e.to_string())?;
        let (tw, _) = root
            .estimate_text_size(&text, &style)
            .map_err(|e| e.to_string())?;
        x += tw as i32 + pt(LABEL_PT);
    }
    Ok(())
}

/// Draws the whole figure onto `root`.
pub(super) fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    plane: &ObservationPlane,
    panels: &[Panel],
    (rows, cols): (usize, usize),
    labels: &Labels,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let top = vmax(&panels.iter().map(|p| p.map).collect::<Vec<_>>());
    for (i, panel) in panels.iter().enumerate() {
        draw_panel(root, lay, plane, panel, top, (i / cols, i % cols))?;
    }
    for t in lay.tick_labels(plane, rows, cols) {
        root.draw(&PathElement::new(
            vec![t.tick.0, t.tick.1],
            BLACK.stroke_width(pt(0.25).max(1) as u32),
        ))
        .map_err(|e| e.to_string())?;
        let pos = if t.horizontal {
            Pos::new(HPos::Center, VPos::Top)
        } else {
            Pos::new(HPos::Right, VPos::Center)
        };
        root.draw_text(&t.text, &lay.text(TICK_PT).pos(pos), t.anchor)
            .map_err(|e| e.to_string())?;
    }
    draw_colorbar(root, lay, rows, top, &labels.colorbar)?;
    if let Some(p) = panels.iter().find(|p| !p.overlay.foci.is_empty()) {
        draw_legend(root, lay, &p.overlay, labels.disk_mm)?;
    }
    let centre = Pos::new(HPos::Center, VPos::Center);
    let label = lay.text(LABEL_PT).pos(centre);
    let rotated = super::rotated_text(LABEL_PT, lay.font_k);
    let grid_w = cols as i32 * lay.pw + (cols as i32 - 1) * lay.gap;
    let grid_h = lay.grid_h(rows);
    let draw = |t: &str, s: &TextStyle, at: (i32, i32)| {
        root.draw_text(t, s, at).map_err(|e| e.to_string())
    };
    draw(
        &labels.x,
        &label,
        (
            lay.x0 + grid_w / 2,
            lay.y0 + grid_h + lay.xtick_h + pt(LABEL_PT * 0.8),
        ),
    )?;
    draw(
        &labels.y,
        &rotated,
        (lay.row_w + pt(LABEL_PT * 0.8), lay.y0 + grid_h / 2),
    )?;
    for (r, t) in labels.rows.iter().enumerate().take(rows) {
        let cy = lay.y0 + r as i32 * (lay.ph + lay.gap) + lay.ph / 2;
        for (k, line) in t.lines().enumerate() {
            draw(line, &rotated, (pt(LABEL_PT * (0.8 + 1.25 * k as f64)), cy))?;
        }
    }
    let cols_y = lay.y0 - pt(LABEL_PT * 0.85);
    for (c, t) in labels.cols.iter().enumerate().take(cols) {
        let cx = lay.x0 + c as i32 * (lay.pw + lay.gap) + lay.pw / 2;
        draw(t, &label, (cx, cols_y))?;
    }
    if !labels.cols_title.is_empty() {
        let y = cols_y - pt(LABEL_PT * 1.3);
        draw(&labels.cols_title, &label, (lay.x0 + grid_w / 2, y))?;
    }
    Ok(())
}

pub(super) fn format_mm(v: f64) -> String {
    if (v - v.round()).abs() < 1e-6 {
        format!("{:.0}", v.round() + 0.0)
    } else {
        format!("{v:.1}")
    }
}

fn format_tick(v: f64, top: f64) -> String {
    if top >= 100.0 {
        format!("{v:.0}")
    } else if top >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2e}")
    }
}

/// Largest finite value of the maps (0 if none).
fn vmax(maps: &[&[f64]]) -> f64 {
    maps.iter()
        .flat_map(|m| m.iter())
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
}
