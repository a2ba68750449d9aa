//! Paper-ready heatmaps of field maps (plotters): PNG (bitmap backend),
//! SVG and PDF ([`crate::pdf`]), sized in millimetres for a one- or
//! two-column figure.
//!
//! Text is DejaVu Sans, embedded in the binary (`host/assets/fonts`,
//! Bitstream Vera licence): rasterised by `ab_glyph` in the PNG, embedded
//! as a TrueType font in the PDF, so plotting needs no system font
//! libraries.
//!
//! A figure is a grid of panels sharing one colour scale, with tick labels
//! only on the outer panels, row and column labels instead of a title, one
//! legend for the overlays and a colour bar. Lengths are laid out in
//! [`UNITS_PER_PT`] backend units per point, so the SVG's `viewBox` is the
//! page size in quarter points and the PNG is 288 dpi.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::ObservationPlane;
use crate::error::InputError;

pub(crate) static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        // The embedded font is a valid TTF; a failure would only lose text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}
/// Drawing failed (file not writable, encoder error).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {msg}")]
pub struct PlotError {
    path: String,
    msg: String,
}

fn err(path: &Path) -> impl Fn(String) -> PlotError + '_ {
    move |msg| PlotError {
        path: path.display().to_string(),
        msg,
    }
}

/// What to draw over a map, in plane coordinates (mm).
#[derive(Debug, Clone, Default)]
pub struct Overlay {
    /// Closed orbit path of the foci.
    pub orbit: Vec<[f64; 2]>,
    /// Focus positions (drawn as small circles).
    pub foci: Vec<[f64; 2]>,
    /// Force-integration disk: centre and diameter (dashed circle).
    pub disk: Option<([f64; 2], f64)>,
}

/// One map panel.
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    /// Row-major map (`plane.nv()` rows of `plane.nu()`).
    pub map: &'a [f64],
    /// Overlays.
    pub overlay: Overlay,
}

/// A figure's file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Bitmap at 288 dpi.
    Png,
    /// Vector (text and overlays as vectors, each heatmap one embedded PNG).
    Svg,
    /// Vector PDF: as the SVG, text in the embedded font, each heatmap one
    /// embedded image.
    Pdf,
}

impl Format {
    /// The file extension.
    pub fn ext(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Svg => "svg",
            Format::Pdf => "pdf",
        }
    }
}

/// One journal column (mm): the default figure width.
pub const ONE_COLUMN_MM: f64 = 88.0;
/// Two journal columns (mm).
pub const TWO_COLUMN_MM: f64 = 180.0;
/// Narrowest figure `--width-mm` takes (mm).
pub const MIN_WIDTH_MM: f64 = 60.0;
/// Widest figure `--width-mm` takes (mm).
pub const MAX_WIDTH_MM: f64 = 500.0;
/// Backend units (SVG user units, PNG pixels) per typographic point.
pub const UNITS_PER_PT: f64 = 4.0;
/// Tick-label size (pt) at the figure's printed width.
pub const TICK_PT: f64 = 7.5;
/// Axis, row, column, legend and colour-bar label size (pt).
pub const LABEL_PT: f64 = 8.0;

/// The printed size and the formats of a figure.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Printed width (mm); the height follows from the panels.
    pub width_mm: f64,
    /// Files written, one per format.
    pub formats: Vec<Format>,
}

impl Default for Figure {
    /// One column wide, PNG, SVG and PDF.
    fn default() -> Self {
        Self {
            width_mm: ONE_COLUMN_MM,
            formats: vec![Format::Png, Format::Svg, Format::Pdf],
        }
    }
}

impl Figure {
    /// Refuses a width outside [`MIN_WIDTH_MM`]..=[`MAX_WIDTH_MM`] (named
    /// as `--width-mm`).
    pub fn check(&self) -> Result<(), InputError> {
        let w = self.width_mm;
        if !(w.is_finite() && (MIN_WIDTH_MM..=MAX_WIDTH_MM).contains(&w)) {
            return Err(InputError::new(format!(
                "--width-mm must be {MIN_WIDTH_MM}..={MAX_WIDTH_MM} mm \
                 (one column {ONE_COLUMN_MM}, two columns {TWO_COLUMN_MM}), got {w}"
            )));
        }
        Ok(())
    }
}

/// What a figure shows besides its panels.
#[derive(Debug, Clone, Default)]
pub struct Labels {
    /// Horizontal axis name with unit, e.g. `a (mm)`.
    pub x: String,
    /// Vertical axis name with unit.
    pub y: String,
    /// Colour-bar label with unit.
    pub colorbar: String,
    /// One label per row, left of it, its lines side by side (none: no row
    /// labels).
    pub rows: Vec<String>,
    /// One label per column, above it (none: no column labels).
    pub cols: Vec<String>,
    /// A line above the column labels naming what they vary (empty: none).
    pub cols_title: String,
    /// Diameter of the force-gauge disk for the legend (mm).
    pub disk_mm: Option<f64>,
}

/// The layout in backend units.
#[derive(Clone)]
struct Layout {
    /// Font size per point: plotters' SVG backend writes size / 1.24, its
    /// bitmap backend draws size as the em height.
    font_k: f64,
    size: (u32, u32),
    /// Top-left of the panel grid.
    x0: i32,
    y0: i32,
    pw: i32,
    ph: i32,
    gap: i32,
    ytick_w: i32,
    xtick_h: i32,
    legend_h: i32,
    row_w: i32,
    bar_x: i32,
}

fn pt(v: f64) -> i32 {
    (v * UNITS_PER_PT).round() as i32
}

impl Layout {
    fn new(
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
        let ytick_w = pt(TICK_PT * 2.6);
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
            ytick_w,
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

    /// For `format`: the SVG and PDF backends take a font's size / 1.24
    /// as its em.
    fn for_format(&self, format: Format) -> Self {
        let k = match format {
            Format::Png => 1.0,
            Format::Svg | Format::Pdf => 1.24,
        };
        Self {
            font_k: UNITS_PER_PT * k,
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

/// Draws panel `i` of a `rows × cols` grid: the map, the overlays, a frame
/// and tick labels where the panel is on the left column or the bottom row.
#[allow(clippy::too_many_arguments)]
fn draw_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    plane: &ObservationPlane,
    panel: &Panel,
    vmax: f64,
    (row, col): (usize, usize),
    rows: usize,
) -> Result<(), String> {
    let (nu, nv) = (plane.nu(), plane.nv());
    let h = plane.step_mm / 2.0;
    let (u0, u1) = (plane.u_mm(0) - h, plane.u_mm(nu - 1) + h);
    let (v0, v1) = (plane.v_mm(0) - h, plane.v_mm(nv - 1) + h);
    let x = lay.x0 + col as i32 * (lay.pw + lay.gap);
    let y = lay.y0 + row as i32 * (lay.ph + lay.gap);
    let left = if col == 0 { lay.ytick_w } else { 0 };
    let bottom = if row + 1 == rows { lay.xtick_h } else { 0 };
    let area = root
        .clone()
        .shrink((x - left, y), (lay.pw + left, lay.ph + bottom));
    let mut chart = ChartBuilder::on(&area)
        .set_label_area_size(LabelAreaPosition::Left, left)
        .set_label_area_size(LabelAreaPosition::Bottom, bottom)
        .build_cartesian_2d(u0..u1, v0..v1)
        .map_err(|e| e.to_string())?;
    // Small panels: ticks keep clear of the panel edges, so neighbours'
    // labels do not touch.
    let small = lay.pw < pt(60.0);
    let (hu, hv) = ((u1 - u0) / 2.0, (v1 - v0) / 2.0);
    let (cu, cv) = ((u1 + u0) / 2.0, (v1 + v0) / 2.0);
    let fx = move |v: &f64| tick_inside(*v, cu, hu, small, true);
    let fy = move |v: &f64| tick_inside(*v, cv, hv, small, false);
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(lay.text(TICK_PT))
        .set_all_tick_mark_size(pt(2.0))
        .axis_style(BLACK.stroke_width(pt(0.25) as u32))
        .draw()
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
fn draw_figure<DB: DrawingBackend>(
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
        draw_panel(root, lay, plane, panel, top, (i / cols, i % cols), rows)?;
    }
    draw_colorbar(root, lay, rows, top, &labels.colorbar)?;
    if let Some(p) = panels.iter().find(|p| !p.overlay.foci.is_empty()) {
        draw_legend(root, lay, &p.overlay, labels.disk_mm)?;
    }
    let centre = Pos::new(HPos::Center, VPos::Center);
    let label = lay.text(LABEL_PT).pos(centre);
    let rotated = TextStyle::from(
        ("sans-serif", LABEL_PT * lay.font_k)
            .into_font()
            .transform(FontTransform::Rotate270),
    )
    .color(&BLACK)
    .pos(centre);
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

/// Writes a `rows × cols` grid of panels sharing one colour scale to
/// `stem` plus each of `fig.formats`' extensions, each file whole or not at
/// all ([`crate::files::write_via`]); returns the paths written.
pub fn figure(
    stem: &Path,
    plane: &ObservationPlane,
    panels: &[Panel],
    (rows, cols): (usize, usize),
    labels: &Labels,
    fig: &Figure,
) -> anyhow::Result<Vec<PathBuf>> {
    register_font();
    let e = err(stem);
    if rows * cols < panels.len() || rows == 0 || cols == 0 {
        return Err(e(format!(
            "{} panels do not fit {rows} × {cols}",
            panels.len()
        ))
        .into());
    }
    fig.check()?;
    let lay = Layout::new(plane, labels, rows, cols, fig);
    let mut written = Vec::new();
    for format in &fig.formats {
        let mut name = stem.as_os_str().to_owned();
        name.push(".");
        name.push(format.ext());
        let path = PathBuf::from(name);
        let e = err(stem);
        let lay = lay.for_format(*format);
        match format {
            Format::Png => crate::files::write_via(&path, |tmp| {
                let root = BitMapBackend::new(tmp, lay.size).into_drawing_area();
                draw_figure(&root, &lay, plane, panels, (rows, cols), labels).map_err(&e)?;
                root.present().map_err(|x| e(crate::files::reason_of(&x)))?;
                Ok(())
            })?,
            Format::Svg => {
                let mut svg = String::new();
                {
                    let root = SVGBackend::with_string(&mut svg, lay.size).into_drawing_area();
                    draw_figure(&root, &lay, plane, panels, (rows, cols), labels).map_err(&e)?;
                    root.present().map_err(|x| e(x.to_string()))?;
                }
                let svg = finish_svg(&svg, lay.size, fig.width_mm);
                crate::files::write_whole(&path, svg.as_bytes())?;
            }
            Format::Pdf => {
                let mut pdf = Vec::new();
                {
                    let backend =
                        crate::pdf::PdfBackend::new(&mut pdf, lay.size, 1.0 / UNITS_PER_PT, FONT)
                            .map_err(|x| e(x.to_string()))?;
                    let root = backend.into_drawing_area();
                    draw_figure(&root, &lay, plane, panels, (rows, cols), labels).map_err(&e)?;
                    root.present().map_err(|x| e(x.to_string()))?;
                }
                crate::files::write_whole(&path, &pdf)?;
            }
        }
        written.push(path);
    }
    Ok(written)
}

/// Gives the SVG its printed size in mm (the `viewBox` stays in units)
/// and its embedded maps the MIME type viewers need (plotters writes
/// `data:png`, which browsers and Inkscape do not show).
fn finish_svg(svg: &str, (w, h): (u32, u32), width_mm: f64) -> String {
    let height_mm = width_mm * h as f64 / w as f64;
    svg.replacen(
        &format!("width=\"{w}\" height=\"{h}\""),
        &format!("width=\"{width_mm:.2}mm\" height=\"{height_mm:.2}mm\""),
        1,
    )
    .replace("href=\"data:png;base64,", "href=\"data:image/png;base64,")
}

/// Writes one heatmap with a colour bar and a legend ([`figure`] with one
/// panel).
pub fn heatmap(
    stem: &Path,
    plane: &ObservationPlane,
    panel: &Panel,
    labels: &Labels,
    fig: &Figure,
) -> anyhow::Result<Vec<PathBuf>> {
    figure(
        stem,
        plane,
        std::slice::from_ref(panel),
        (1, 1),
        labels,
        fig,
    )
}

/// The axis names of a plane in scene terms: the scene's LM plane axes `a`
/// and `b` when the plane lies along them, else the direction in scene
/// coordinates; both in mm from the plane centre.
pub fn axis_names(plane: &ObservationPlane, lm_a: [f64; 3], lm_b: [f64; 3]) -> (String, String) {
    let same = |p: [f64; 3], q: [f64; 3]| p.iter().zip(&q).all(|(x, y)| (x - y).abs() < 1e-9);
    let name = |axis: [f64; 3], fallback: &str| {
        if same(axis, lm_a) {
            "a (mm)".to_string()
        } else if same(axis, lm_b) {
            "b (mm)".to_string()
        } else {
            let n = |v: f64| format!("{}", (v * 100.0).round() / 100.0 + 0.0);
            format!(
                "{fallback} ∥ ({}, {}, {}) (mm)",
                n(axis[0]),
                n(axis[1]),
                n(axis[2])
            )
        }
    };
    (name(plane.u, "u"), name(plane.v, "v"))
}

/// Viridis colour map at `t` ∈ [0, 1] (clamped).
pub fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |p: u8, q: u8| (p as f64 + f * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The label of tick `v` on an axis centred on `c` with half-width `h`:
/// when `small`, none in the outer quarter, nor (`sparse`: on a horizontal
/// axis, where labels sit side by side) in the inner quarter.
fn tick_inside(v: f64, c: f64, h: f64, small: bool, sparse: bool) -> String {
    let d = (v - c).abs();
    if small && (d > 0.75 * h || (sparse && d < 0.25 * h)) {
        String::new()
    } else {
        format_mm(v)
    }
}

fn format_mm(v: f64) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends_and_clamps() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
    }

    #[test]
    fn heatmap_writes_png_svg_and_pdf_at_the_printed_width() {
        let plane = ObservationPlane {
            center_mm: [0.0; 3],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            width_mm: 4.0,
            height_mm: 4.0,
            step_mm: 0.5,
        };
        let map: Vec<f64> = (0..plane.nu() * plane.nv()).map(|i| i as f64).collect();
        let dir = std::env::temp_dir().join(format!("lmhost-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let panel = Panel {
            map: &map,
            overlay: Overlay {
                orbit: vec![[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]],
                foci: vec![[1.0, 0.0]],
                disk: Some(([0.0, 0.0], 3.0)),
            },
        };
        let (x, y) = axis_names(&plane, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!((x.as_str(), y.as_str()), ("a (mm)", "v ∥ (0, 1, 0) (mm)"));
        let labels = Labels {
            x,
            y,
            colorbar: "p (Pa)".into(),
            disk_mm: Some(3.0),
            ..Labels::default()
        };
        let fig = Figure {
            width_mm: TWO_COLUMN_MM,
            ..Figure::default()
        };
        let written = heatmap(&dir.join("t"), &plane, &panel, &labels, &fig).unwrap();
        assert_eq!(
            written,
            [dir.join("t.png"), dir.join("t.svg"), dir.join("t.pdf")]
        );
        let bytes = std::fs::read(dir.join("t.png")).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        // 180 mm at 4 units per pt: 2041 pixels (288 dpi).
        assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 2041);
        let svg = std::fs::read_to_string(dir.join("t.svg")).unwrap();
        assert!(svg.starts_with("<svg width=\"180.00mm\""));
        assert!(svg.contains("3 mm gauge disk") && svg.contains("p (Pa)"));
        let e = figure(
            &dir.join("g"),
            &plane,
            &[panel.clone(), panel],
            (1, 1),
            &labels,
            &fig,
        );
        assert!(e.unwrap_err().to_string().contains("do not fit"));
        let narrow = Figure {
            width_mm: 10.0,
            ..Figure::default()
        };
        assert!(narrow.check().unwrap_err().0.contains("--width-mm"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
