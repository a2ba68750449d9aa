//! `lmhost simulate --compare`: LM-S against LM-M at the paper's radii,
//! as grid figures, maps and one summary.

use std::path::Path;

use anyhow::Context;
use serde_json::json;

use crate::field::plot::{self, Overlay, Panel};
use crate::field::study::{View, overlay, simulate_plan};
use crate::field::{self, FieldMaps, npy};
use crate::sequence::Plan;

/// Radii of the `--compare` grid (the paper's conditions).
pub const COMPARE_RADII_MM: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];

/// A map of [`FieldMaps`].
type Pick = fn(&FieldMaps) -> &Vec<f64>;

/// The maps the comparison shows: file and summary key, title, unit, the
/// summary key of its per-panel normalisation, the map.
const COMPARE_MAPS: [(&str, &str, &str, &str, Pick); 2] = [
    (
        "mean_pressure",
        "Time-averaged radiation pressure",
        "Pa",
        "normalisation_pa",
        |m| &m.mean_pressure_pa,
    ),
    (
        "lm_power",
        "Radiation-pressure power at the LM frequency",
        "Pa²",
        "normalisation_pa2",
        |m| &m.lm_power_pa2,
    ),
];

/// Plans (with `plan_for(foci, radius_mm)`) and simulates LM-S and LM-M
/// with `multi` foci at every radius of [`COMPARE_RADII_MM`], and writes the
/// grid figures (shared scale and each panel on its own peak), two maps per
/// stimulus and `summary.json` into `out`.
pub fn compare(
    multi: usize,
    mut plan_for: impl FnMut(usize, f64) -> anyhow::Result<Plan>,
    view: &View,
    out: &Path,
) -> anyhow::Result<()> {
    let mut sims = Vec::new();
    for (kind, foci) in [("LM-S", 1), ("LM-M", multi)] {
        for r in COMPARE_RADII_MM {
            let plan =
                plan_for(foci, r).with_context(|| format!("planning {kind} at A = {r} mm"))?;
            let sim = simulate_plan(&plan, view)?;
            sims.push((kind, r, plan, sim));
        }
    }
    let plane = sims[0].3.plane;
    let mut summary = Vec::new();
    for (key, title, unit, _, pick) in COMPARE_MAPS {
        let stem = format!("compare_{key}");
        let panels: Vec<Panel> = sims
            .iter()
            .map(|(kind, r, plan, sim)| Panel {
                title: format!("{kind}, A = {r} mm"),
                map: pick(&sim.maps),
                overlay: Overlay {
                    disk: None,
                    ..overlay(plan, &sim.plane, view.disk_mm)
                },
            })
            .collect();
        let shared_title = format!("{title} (shared scale; LM-M: {multi} foci)");
        plot::grid(
            &out.join(format!("{stem}.png")),
            &plane,
            &panels,
            2,
            5,
            &shared_title,
            unit,
        )?;
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
                title: p.title.clone(),
                map: m,
                overlay: p.overlay.clone(),
            })
            .collect();
        plot::grid(
            &out.join(format!("{stem}_normalised.png")),
            &plane,
            &norm_panels,
            2,
            5,
            &format!("{title} (each panel / its own peak; LM-M: {multi} foci)"),
            "",
        )?;
    }
    for (kind, r, plan, sim) in &sims {
        let stem = format!("{}_{r}mm", kind.to_lowercase().replace('-', ""));
        let mut s = sim.summary_json(plan, view, *r);
        s["stem"] = json!(stem);
        // Name only the files this run wrote.
        let mut maps = serde_json::Map::new();
        for (key, title, unit, norm_key, pick) in COMPARE_MAPS {
            let map = pick(&sim.maps);
            let npy_name = format!("{stem}_{key}.npy");
            npy::write_f64(&out.join(&npy_name), sim.maps.nv, sim.maps.nu, map)?;
            let mut m = json!({
                "title": title, "unit": unit,
                "npy": npy_name,
                "png": format!("compare_{key}.png"),
                "png_normalised": format!("compare_{key}_normalised.png"),
                "peak": sim.peak_json(map),
            });
            m[norm_key] = json!(field::peak(map).map_or(0.0, |p| p.1));
            maps.insert(key.to_string(), m);
        }
        s["maps"] = serde_json::Value::Object(maps);
        summary.push(s);
        crate::outln!(
            "{kind} A = {r} mm: {}",
            sim.text_summary(plan, *r).replace('\n', "; ")
        )?;
    }
    let path = out.join("summary.json");
    let text = serde_json::to_string_pretty(&json!({
        "compare": summary,
        "normalisation": "png_normalised panels (and normalisation_* values) divide each \
            panel's map by its own peak, as the paper's figures do; png panels share one scale",
    }))? + "\n";
    // Last: a summary.json exists only when every file it names was written.
    crate::files::write_whole(&path, text.as_bytes())?;
    crate::outln!("wrote {}", out.display())?;
    Ok(())
}
