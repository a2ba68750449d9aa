//! Paper-ready heatmaps of field maps (plotters): PNG (bitmap backend),
//! SVG and PDF ([`crate::pdf`]), sized in millimetres for a one- or
//! two-column figure; the drawing itself is `draw`'s.
//!
//! Text is DejaVu Sans, embedded in the binary (`host/assets/fonts`,
//! Bitstream Vera licence): rasterised by `ab_glyph` in the PNG, embedded
//! as a TrueType subset in the PDF, so plotting needs no system font
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

mod draw;

use self::draw::{Layout, draw_figure};
use super::ObservationPlane;
use crate::error::InputError;

pub(crate) static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
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

/// Writes a `rows × cols` grid of panels sharing one colour scale to
/// `stem` plus each of `fig.formats`' extensions, each file whole or not at
/// all ([`crate::files::Output`]); returns the paths written.
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
    let grid = Grid {
        lay: Layout::new(plane, labels, rows, cols, fig),
        plane,
        panels,
        shape: (rows, cols),
        labels,
    };
    write_formats(stem, fig, &grid)
}

/// The panel grid [`figure`] draws.
struct Grid<'a> {
    lay: Layout,
    plane: &'a ObservationPlane,
    panels: &'a [Panel<'a>],
    shape: (usize, usize),
    labels: &'a Labels,
}

impl Drawing for Grid<'_> {
    fn size(&self) -> (u32, u32) {
        self.lay.size
    }

    fn draw<B: DrawingBackend>(&self, on: &Canvas<B>, font_k: f64) -> Result<(), String> {
        let lay = self.lay.with_font_k(font_k);
        draw_figure(on, &lay, self.plane, self.panels, self.shape, self.labels)
    }
}

/// A figure laid out once, drawn alike on each backend by
/// [`write_formats`].
pub trait Drawing {
    /// The canvas, backend units ([`UNITS_PER_PT`] per point).
    fn size(&self) -> (u32, u32);
    /// Draws it on `on`, a point of font size being `font_k` backend
    /// units ([`font_k`]).
    fn draw<B: DrawingBackend>(&self, on: &Canvas<B>, font_k: f64) -> Result<(), String>;
}

/// The whole drawing area of a backend.
pub type Canvas<B> = DrawingArea<B, Shift>;

/// Backend units per point of font size in `format`: the SVG and PDF
/// backends take a font's size / 1.24 as its em.
pub fn font_k(format: Format) -> f64 {
    UNITS_PER_PT
        * match format {
            Format::Png => 1.0,
            Format::Svg | Format::Pdf => 1.24,
        }
}

/// Black sans-serif text of `size_pt` points turned a quarter anticlockwise
/// (a y-axis title), centred on where it is drawn.
pub fn rotated_text(size_pt: f64, font_k: f64) -> TextStyle<'static> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    TextStyle::from(
        ("sans-serif", size_pt * font_k)
            .into_font()
            .transform(FontTransform::Rotate270),
    )
    .color(&BLACK)
    .pos(Pos::new(HPos::Center, VPos::Center))
}

/// Writes `drawing` to `stem` plus each of `fig.formats`' extensions at
/// `fig.width_mm`, each file whole or absent ([`crate::files::write_whole`]);
/// returns the paths written.
pub fn write_formats(
    stem: &Path,
    fig: &Figure,
    drawing: &impl Drawing,
) -> anyhow::Result<Vec<PathBuf>> {
    register_font();
    let size = drawing.size();
    let mut written = Vec::new();
    for &format in &fig.formats {
        let mut name = stem.as_os_str().to_owned();
        name.push(".");
        name.push(format.ext());
        let path = PathBuf::from(name);
        let e = err(&path);
        let k = font_k(format);
        match format {
            Format::Png => write_png(&path, size, |root| Ok(drawing.draw(root, k).map_err(&e)?))?,
            Format::Svg => {
                let mut svg = String::new();
                {
                    let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                    drawing.draw(&root, k).map_err(&e)?;
                    root.present().map_err(|x| e(x.to_string()))?;
                }
                let svg = finish_svg(&svg, size, fig.width_mm);
                crate::files::write_whole(&path, svg.as_bytes())?;
            }
            Format::Pdf => {
                let mut pdf = Vec::new();
                {
                    let backend =
                        crate::pdf::PdfBackend::new(&mut pdf, size, 1.0 / UNITS_PER_PT, FONT)
                            .map_err(|x| e(x.to_string()))?;
                    let root = backend.into_drawing_area();
                    drawing.draw(&root, k).map_err(&e)?;
                    root.present().map_err(|x| e(x.to_string()))?;
                }
                crate::files::write_whole(&path, &pdf)?;
            }
        }
        written.push(path.clone());
    }
    Ok(written)
}

/// Draws a `size` pixel bitmap with `draw` and writes it to `path` as a
/// PNG, whole or not at all: encoded in memory, then written as every
/// output is ([`crate::files::write_whole`]).
pub fn write_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    use image::ImageEncoder as _;
    let e = err(path);
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root)?;
        root.present().map_err(|x| e(x.to_string()))?;
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgb, size.0, size.1, image::ColorType::Rgb8)
        .map_err(|x| e(x.to_string()))?;
    crate::files::write_whole(path, &png)
}

/// Gives the SVG its printed size in mm (the `viewBox` stays in units)
/// and its embedded maps the MIME type viewers need (plotters writes
/// `data:png`, which browsers and Inkscape do not show).
pub(crate) fn finish_svg(svg: &str, (w, h): (u32, u32), width_mm: f64) -> String {
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
        let plane = ObservationPlane::xy([0.0; 3], 4.0, 4.0, 0.5);
        let map: Vec<f64> = (0..plane.nu() * plane.nv()).map(|i| i as f64).collect();
        let dir = crate::files::scratch("plot");
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
