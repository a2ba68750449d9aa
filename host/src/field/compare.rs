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
    for (stem, title, unit, pick) in [
        (
            "compare_mean_pressure",
            "Time-averaged radiation pressure",
            "Pa",
            (|m: &FieldMaps| &m.mean_pressure_pa) as fn(&FieldMaps) -> &Vec<f64>,
        ),
        (
            "compare_lm_power",
            "Radiation-pressure power at the LM frequency",
            "Pa²",
            |m: &FieldMaps| &m.lm_power_pa2,
        ),
    ] {
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
        npy::write_f64(
            &out.join(format!("{stem}_mean_pressure.npy")),
            sim.maps.nv,
            sim.maps.nu,
            &sim.maps.mean_pressure_pa,
        )?;
        npy::write_f64(
            &out.join(format!("{stem}_lm_power.npy")),
            sim.maps.nv,
            sim.maps.nu,
            &sim.maps.lm_power_pa2,
        )?;
        let mut s = sim.summary_json(plan, view, *r);
        s["stem"] = json!(stem);
        // Name only the files this run wrote.
        let pk = |m: &[f64]| field::peak(m).map_or(0.0, |p| p.1);
        s["maps"] = json!({
            "mean_pressure": {
                "title": "Time-averaged radiation pressure", "unit": "Pa",
                "npy": format!("{stem}_mean_pressure.npy"),
                "png": "compare_mean_pressure.png",
                "png_normalised": "compare_mean_pressure_normalised.png",
                "peak": sim.peak_json(&sim.maps.mean_pressure_pa),
                "normalisation_pa": pk(&sim.maps.mean_pressure_pa),
            },
            "lm_power": {
                "title": "Radiation-pressure power at the LM frequency", "unit": "Pa²",
                "npy": format!("{stem}_lm_power.npy"),
                "png": "compare_lm_power.png",
                "png_normalised": "compare_lm_power_normalised.png",
                "peak": sim.peak_json(&sim.maps.lm_power_pa2),
                "normalisation_pa2": pk(&sim.maps.lm_power_pa2),
            },
        });
        summary.push(s);
        println!(
            "{kind} A = {r} mm: {}",
            sim.text_summary(plan, *r).replace('\n', "; ")
        );
    }
    let path = out.join("summary.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&json!({
            "compare": summary,
            "normalisation": "png_normalised panels (and normalisation_* values) divide each \
                panel's map by its own peak, as the paper's figures do; png panels share one scale",
        }))? + "\n",
    )
    .with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}
