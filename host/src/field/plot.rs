//! PNG heatmaps of field maps (plotters, bitmap backend).
//!
//! Text is rasterised by `ab_glyph` from DejaVu Sans, embedded in the
//! binary (`host/assets/fonts`, Bitstream Vera licence), so plotting needs
//! no system font libraries.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::FontStyle;

use super::ObservationPlane;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
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
    /// Title above the panel.
    pub title: String,
    /// Row-major map (`plane.nv()` rows of `plane.nu()`).
    pub map: &'a [f64],
    /// Overlays.
    pub overlay: Overlay,
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

/// Draw one panel into `area` with colour scale `0..=vmax`.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    plane: &ObservationPlane,
    panel: &Panel,
    vmax: f64,
    font_px: u32,
) -> Result<(), String> {
    let (nu, nv) = (plane.nu(), plane.nv());
    let h = plane.step_mm / 2.0;
    let (u0, u1) = (plane.u_mm(0) - h, plane.u_mm(nu - 1) + h);
    let (v0, v1) = (plane.v_mm(0) - h, plane.v_mm(nv - 1) + h);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", font_px + 2))
        .margin(6)
        .x_label_area_size(font_px * 2 + 8)
        .y_label_area_size(font_px * 2 + 12)
        .build_cartesian_2d(u0..u1, v0..v1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_desc("u (mm)")
        .y_desc("v (mm)")
        .x_label_formatter(&|v| format_mm(*v))
        .y_label_formatter(&|v| format_mm(*v))
        .label_style(("sans-serif", font_px))
        .axis_desc_style(("sans-serif", font_px))
        .draw()
        .map_err(|e| e.to_string())?;
    let scale = if vmax > 0.0 { 1.0 / vmax } else { 0.0 };
    chart
        .draw_series((0..nv).flat_map(|iv| {
            (0..nu).map(move |iu| {
                let (u, v) = (plane.u_mm(iu), plane.v_mm(iv));
                let c = viridis(panel.map[iv * nu + iu] * scale);
                Rectangle::new([(u - h, v - h), (u + h, v + h)], c.filled())
            })
        }))
        .map_err(|e| e.to_string())?;
    let o = &panel.overlay;
    if o.orbit.len() > 1 {
        let mut path: Vec<(f64, f64)> = o.orbit.iter().map(|p| (p[0], p[1])).collect();
        path.push(path[0]);
        chart
            .draw_series(std::iter::once(PathElement::new(
                path,
                WHITE.stroke_width(1),
            )))
            .map_err(|e| e.to_string())?;
    }
    chart
        .draw_series(
            o.foci
                .iter()
                .map(|p| Circle::new((p[0], p[1]), 4, RED.stroke_width(2))),
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
            PathElement::new(pts, WHITE.mix(0.8).stroke_width(1))
        });
        chart.draw_series(arcs).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Draw a vertical colour bar for `0..=vmax` labelled `unit`.
fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    vmax: f64,
    unit: &str,
    font_px: u32,
) -> Result<(), String> {
    let top = if vmax > 0.0 { vmax } else { 1.0 };
    let mut chart = ChartBuilder::on(area)
        .margin_top(font_px * 2 + 12)
        .margin_bottom(font_px * 2 + 14)
        .margin_right(4)
        .y_label_area_size(font_px * 4 + 8)
        .build_cartesian_2d(0.0..1.0, 0.0..top)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_desc(unit)
        .y_label_formatter(&|v| format_tick(*v, top))
        .label_style(("sans-serif", font_px))
        .axis_desc_style(("sans-serif", font_px))
        .draw()
        .map_err(|e| e.to_string())?;
    let n = 200;
    chart
        .draw_series((0..n).map(|i| {
            let (a, b) = (top * i as f64 / n as f64, top * (i + 1) as f64 / n as f64);
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                viridis((i as f64 + 0.5) / n as f64).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
    Ok(())
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

/// Write one heatmap with a colour bar to `path` (PNG), whole or not at
/// all ([`crate::files::write_via`]).
pub fn heatmap(
    path: &Path,
    plane: &ObservationPlane,
    panel: &Panel,
    unit: &str,
) -> anyhow::Result<()> {
    register_font();
    let e = err(path);
    crate::files::write_via(path, |tmp| {
        let root = BitMapBackend::new(tmp, (760, 640)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let (main, bar) = root.split_horizontally(640);
        let top = vmax(&[panel.map]);
        draw_panel(&main, plane, panel, top, 16).map_err(&e)?;
        draw_colorbar(&bar, top, unit, 14).map_err(&e)?;
        root.present().map_err(|x| e(crate::files::reason_of(&x)))?;
        Ok(())
    })
}

/// Write a grid of panels sharing one colour scale to `path` (PNG).
/// `rows × cols` must hold every panel.
pub fn grid(
    path: &Path,
    plane: &ObservationPlane,
    panels: &[Panel],
    rows: usize,
    cols: usize,
    title: &str,
    unit: &str,
) -> anyhow::Result<()> {
    register_font();
    let e = err(path);
    if rows * cols < panels.len() || rows == 0 || cols == 0 {
        return Err(e(format!(
            "{} panels do not fit {rows} × {cols}",
            panels.len()
        ))
        .into());
    }
    let (pw, ph) = (300u32, 300u32);
    let bar_w = 110u32;
    let title_h = 40u32;
    let size = (pw * cols as u32 + bar_w, ph * rows as u32 + title_h);
    crate::files::write_via(path, |tmp| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 22))
            .map_err(|x| e(x.to_string()))?;
        let (main, bar) = root.split_horizontally(pw * cols as u32);
        let top = vmax(&panels.iter().map(|p| p.map).collect::<Vec<_>>());
        for (area, panel) in main.split_evenly((rows, cols)).iter().zip(panels) {
            draw_panel(area, plane, panel, top, 12).map_err(&e)?;
        }
        draw_colorbar(&bar, top, unit, 13).map_err(&e)?;
        root.present().map_err(|x| e(crate::files::reason_of(&x)))?;
        Ok(())
    })
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
    fn heatmap_writes_a_png() {
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
        let path = dir.join("t.png");
        let panel = Panel {
            title: "test".into(),
            map: &map,
            overlay: Overlay {
                orbit: vec![[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]],
                foci: vec![[1.0, 0.0]],
                disk: Some(([0.0, 0.0], 3.0)),
            },
        };
        heatmap(&path, &plane, &panel, "Pa").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        grid(
            &dir.join("g.png"),
            &plane,
            &[panel.clone(), panel],
            1,
            2,
            "t",
            "Pa",
        )
        .unwrap();
        assert!(std::fs::metadata(dir.join("g.png")).unwrap().len() > 1000);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
