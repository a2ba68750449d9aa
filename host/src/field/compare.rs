//! `lmhost simulate --compare`: the paper's grid of conditions (rows:
//! LM-S 5 Hz, LM-M 5 Hz, LM-S 25 Hz with 4 mm steps) at its radii
//! (columns: 2-6 mm), as figures, maps and one summary.

use std::path::Path;

use anyhow::Context;
use serde_json::json;

use crate::field::plot::{self, Figure, Labels, Panel};
use crate::field::study::{View, labels, overlay, simulate_plan};
use crate::field::{self, FieldMaps};
use crate::npy;
use crate::plan::sequence::Plan;

/// Radii of the `--compare` grid (the paper's conditions).
pub const COMPARE_RADII_MM: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];
/// The paper's fast LM-S condition: its frequency (Hz) ...
pub const FAST_FREQ_HZ: f64 = 25.0;
/// ... and its step width d_LM (mm).
pub const FAST_STEP_MM: f64 = 4.0;

/// One row of the grid: a stimulus condition, planned at every radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// Foci (1: LM-S).
    pub foci: usize,
    /// LM frequency (Hz).
    pub freq_hz: f64,
    /// Step width d_LM (mm); `None`: the caller's own (the plan flags').
    pub step_mm: Option<f64>,
}

impl Condition {
    /// `LM-S` or `LM-M`.
    pub fn kind(&self) -> &'static str {
        if self.foci > 1 { "LM-M" } else { "LM-S" }
    }

    /// The row label, two lines: kind, frequency.
    pub fn label(&self) -> String {
        format!("{}\n{} Hz", self.kind(), crate::limits::Num(self.freq_hz))
    }

    /// File-name stem at radius `r` (mm), e.g. `lms_25hz_2mm`.
    pub fn stem(&self, r: f64) -> String {
        format!(
            "{}_{}hz_{r}mm",
            self.kind().to_lowercase().replace('-', ""),
            crate::limits::Num(self.freq_hz)
        )
    }
}

/// The paper's three rows: LM-S and LM-M (`multi` foci) at `freq_hz` with
/// the caller's step, then LM-S at [`FAST_FREQ_HZ`] with
/// [`FAST_STEP_MM`] steps.
pub fn paper_conditions(multi: usize, freq_hz: f64) -> [Condition; 3] {
    [
        Condition {
            foci: 1,
            freq_hz,
            step_mm: None,
        },
        Condition {
            foci: multi,
            freq_hz,
            step_mm: None,
        },
        Condition {
            foci: 1,
            freq_hz: FAST_FREQ_HZ,
            step_mm: Some(FAST_STEP_MM),
        },
    ]
}

/// A map of [`FieldMaps`].
type Pick = fn(&FieldMaps) -> &Vec<f64>;

/// The maps the comparison shows: file and summary key, title, unit, the
/// summary key of its per-panel normalisation, the colour-bar label, the map.
const COMPARE_MAPS: [(&str, &str, &str, &str, &str, Pick); 2] = [
    (
        "mean_pressure",
        "Time-averaged radiation pressure",
        "Pa",
        "normalisation_pa",
        "mean rad. pressure (Pa)",
        |m| &m.mean_pressure_pa,
    ),
    (
        "lm_power",
        "Radiation-pressure power at the LM frequency",
        "Pa²",
        "normalisation_pa2",
        "power at f_LM (Pa²)",
        |m| &m.lm_power_pa2,
    ),
];

/// Plans (with `plan_for(condition, radius_mm)`) and simulates every
/// condition (a row each) at every radius of [`COMPARE_RADII_MM`] (a column
/// each), and writes the grid figures (shared scale and each panel on its
/// own peak) in `fig`'s formats, two maps per stimulus and `summary.json`
/// into `out`.
pub fn compare(
    conditions: &[Condition],
    mut plan_for: impl FnMut(&Condition, f64) -> anyhow::Result<Plan>,
    view: &View,
    fig: &Figure,
    out: &Path,
) -> anyhow::Result<()> {
    anyhow::ensure!(!conditions.is_empty(), "no conditions to compare");
    let mut sims = Vec::new();
    for c in conditions {
        for r in COMPARE_RADII_MM {
            let plan = plan_for(c, r).with_context(|| {
                format!(
                    "planning {} at {} Hz, A = {r} mm",
                    c.kind(),
                    crate::limits::Num(c.freq_hz)
                )
            })?;
            let sim = simulate_plan(&plan, view)?;
            sims.push((c, r, plan, sim));
        }
    }
    let plane = sims[0].3.plane;
    let shape = (conditions.len(), COMPARE_RADII_MM.len());
    let base = Labels {
        rows: conditions.iter().map(Condition::label).collect(),
        cols: COMPARE_RADII_MM
            .iter()
            .map(|r| format!("{} mm", crate::limits::Num(*r)))
            .collect(),
        cols_title: "orbit radius A".into(),
        ..labels(&sims[0].2, &plane, view.disk_mm)
    };
    let mut files = serde_json::Map::new();
    for (key, _, _, _, colorbar, pick) in COMPARE_MAPS {
        let stem = format!("compare_{key}");
        let panels: Vec<Panel> = sims
            .iter()
            .map(|(_, _, plan, sim)| Panel {
                map: pick(&sim.maps),
                overlay: overlay(plan, &sim.plane, view.disk_mm),
            })
            .collect();
        let shared = Labels {
            colorbar: colorbar.into(),
            ..base.clone()
        };
        let written = plot::figure(&out.join(&stem), &plane, &panels, shape, &shared, fig)?;
        // The paper normalises each map to its own peak.
        let norm_maps: Vec<Vec<f64>> = sims
            .iter()
            .map(|(_, _, _, sim)| {
                let m = pick(&sim.maps);
                let peak = field::peak(m).map_or(0.0, |p| p.1);
                m.iter()
                    .map(|v| if peak > 0.0 { v / peak } else { 0.0 })
                    .collect()
            })
            .collect();
        let norm_panels: Vec<Panel> = panels
            .iter()
            .zip(&norm_maps)
            .map(|(p, m)| Panel {
                map: m,
                overlay: p.overlay.clone(),
            })
            .collect();
        let norm = Labels {
            colorbar: "relative to panel peak".into(),
            ..base.clone()
        };
        let written_norm = plot::figure(
            &out.join(format!("{stem}_normalised")),
            &plane,
            &norm_panels,
            shape,
            &norm,
            fig,
        )?;
        // `png`, `png_normalised`, `svg`, ...: the files this run wrote.
        let mut named = serde_json::Map::new();
        for (paths, suffix) in [(&written, ""), (&written_norm, "_normalised")] {
            for p in paths.iter() {
                let ext = p
                    .extension()
                    .map_or(String::new(), |e| e.to_string_lossy().into());
                let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
                named.insert(format!("{ext}{suffix}"), json!(name));
            }
        }
        files.insert(key.to_string(), serde_json::Value::Object(named));
    }
    let mut summary = Vec::new();
    for (c, r, plan, sim) in &sims {
        let stem = c.stem(*r);
        let mut s = sim.summary_json(plan, view, *r);
        s["stem"] = json!(stem);
        s["condition"] = json!({
            "kind": c.kind(),
            "freq_hz": c.freq_hz,
            "step_mm": c.step_mm,
        });
        // Name only the files this run wrote.
        let mut maps = serde_json::Map::new();
        for (key, title, unit, norm_key, _, pick) in COMPARE_MAPS {
            let map = pick(&sim.maps);
            let npy_name = format!("{stem}_{key}.npy");
            npy::write_f64(&out.join(&npy_name), sim.maps.nv, sim.maps.nu, map)?;
            let mut m = json!({
                "title": title, "unit": unit,
                "npy": npy_name,
                "peak": sim.peak_json(map),
            });
            if let (Some(m), Some(f)) = (m.as_object_mut(), files[key].as_object()) {
                m.extend(f.clone());
            }
            m[norm_key] = json!(field::peak(map).map_or(0.0, |p| p.1));
            maps.insert(key.to_string(), m);
        }
        s["maps"] = serde_json::Value::Object(maps);
        summary.push(s);
        crate::outln!(
            "{} {} Hz A = {r} mm: {}",
            c.kind(),
            crate::limits::Num(c.freq_hz),
            sim.text_summary(plan, *r).replace('\n', "; ")
        )?;
    }
    let path = out.join("summary.json");
    let text = serde_json::to_string_pretty(&json!({
        "compare": summary,
        "layout": "rows: conditions in the order of `compare` (every radius of one \
            condition, then the next); columns: radii",
        "normalisation": "the normalised figures (and normalisation_* values) divide each \
            panel's map by its own peak, as the paper's figures do; the others share one scale",
    }))? + "\n";
    // Last: a summary.json exists only when every file it names was written.
    crate::files::write_whole(&path, text.as_bytes())?;
    crate::outln!("wrote {}", out.display())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::scene::Scene;
    use crate::plan::sequence::Synthesis;
    use crate::plan::trajectory::{LmParams, Steps};

    /// Every `font-size` in `svg`, in points at its printed width.
    fn font_sizes_pt(svg: &str) -> Vec<f64> {
        let attr = |name: &str| {
            let at = svg.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
            svg[at..].split('"').next().unwrap().to_string()
        };
        let width_mm: f64 = attr("width").trim_end_matches("mm").parse().unwrap();
        let view_w: f64 = attr("viewBox").split(' ').nth(2).unwrap().parse().unwrap();
        let pt_per_unit = width_mm / 25.4 * 72.0 / view_w;
        svg.split("font-size=\"")
            .skip(1)
            .map(|s| s.split('"').next().unwrap().parse::<f64>().unwrap() * pt_per_unit)
            .collect()
    }

    #[test]
    fn compare_grid_svg_names_its_axes_has_a_legend_and_legible_text() {
        let dir = crate::files::scratch("compare");
        let view = View {
            size_mm: (12.0, 12.0),
            step_mm: 2.0,
            ..View::default()
        };
        let fig = Figure {
            width_mm: plot::ONE_COLUMN_MM,
            formats: vec![plot::Format::Svg],
        };
        let conditions = paper_conditions(4, 5.0);
        let plan_for = |c: &Condition, r: f64| {
            let scene = Scene::default();
            let mut p = LmParams::paper(scene.center_mm);
            p.cycle.radius_mm = r;
            p.cycle.foci = c.foci;
            p.cycle.freq_hz = c.freq_hz;
            if let Some(s) = c.step_mm {
                p.cycle.steps = Steps::Width(s);
            }
            Ok(Plan::new(scene, &p, &Synthesis::Linear)?)
        };
        compare(&conditions, plan_for, &view, &fig, &dir).unwrap();
        let svg = std::fs::read_to_string(dir.join("compare_mean_pressure.svg")).unwrap();
        assert!(svg.starts_with("<svg width=\"88.00mm\""), "{}", &svg[..80]);
        // Axes in the scene's terms, with units; the colour bar's unit.
        for text in ["a (mm)", "b (mm)", "(Pa)", "orbit radius A", "6 mm"] {
            assert!(svg.contains(text), "no `{text}`");
        }
        // The legend, and the 3 × 5 rows: no title.
        for text in ["orbit", "foci", "15 mm gauge disk", "LM-S", "LM-M", "25 Hz"] {
            assert!(svg.contains(text), "no `{text}`");
        }
        assert_eq!(svg.matches("href=\"data:image/png;base64,").count(), 15);
        let sizes = font_sizes_pt(&svg);
        assert!(sizes.len() > 20, "{sizes:?}");
        let min = sizes.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(min >= 7.0, "smallest text {min} pt");
        // The 25 Hz row steps 4 mm: N = round(2π · 6 / 4) = 9 at A = 6 mm.
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
        let runs = s["compare"].as_array().unwrap();
        assert_eq!(runs.len(), 15);
        assert_eq!(runs[14]["stimulus"]["steps"], 9);
        assert_eq!(runs[14]["condition"]["freq_hz"], 25.0);
        assert_eq!(runs[9]["stimulus"]["foci"], 4);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
