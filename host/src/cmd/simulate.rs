//! `lmhost simulate`: plan a stimulus, simulate its acoustic field on the
//! LM plane and write heatmaps (PNG), maps (`.npy`) and a JSON summary.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use serde_json::json;

use crate::cmd::plan::{PlanArgs, parse_vec3};
use crate::error::InputError;
use crate::field::plot::{self, Overlay, Panel};
use crate::field::{self, FieldMaps, ObservationPlane, Radiation, npy};
use crate::limits;
use crate::sequence::Plan;

/// Simulate the acoustic field of an LM stimulus and plot it.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Writes into --out: mean_pressure.png (time-averaged radiation \
    pressure), lm_power.png (power at the LM frequency), pressure.png and amplitude.png \
    (step 0), one .npy per map and summary.json.\n\nExamples:\n  \
    lmhost simulate --radius 3 --foci 4 --out lmm3\n  \
    lmhost simulate --scene scenes/paper.toml --radius 3 --out paper\n  \
    lmhost simulate --compare --out compare       # LM-S vs LM-M, A = 2..6 mm"
)]
pub struct Args {
    #[command(flatten)]
    plan: PlanArgs,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", default_value = "simulate-out")]
    out: PathBuf,
    /// Observation plane size in mm, each at most 1000: `S` (square) or
    /// `W,H` [default: 20].
    #[arg(long, value_name = "MM[,MM]")]
    plane_size: Option<String>,
    /// Observation grid step in mm. The whole run is limited to 5e10
    /// points × transducers × steps (5e9 with --reference), ~10 s.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.2,
        allow_negative_numbers = true
    )]
    plane_step: f64,
    /// Observation plane centre X,Y,Z in mm [default: the LM centre].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    plane_center: Option<String>,
    /// Observation plane axes `UX,UY,UZ,VX,VY,VZ` [default: the scene's LM
    /// plane axes a, b].
    #[arg(long, value_name = "UX,UY,UZ,VX,VY,VZ", allow_hyphen_values = true)]
    plane_axes: Option<String>,
    /// Radiation-pressure coefficient α in α|p|²/(2ρc²), above 0 and at
    /// most 2 (2 = perfect reflector).
    #[arg(long, value_name = "A", default_value_t = field::DEFAULT_RADIATION_ALPHA, allow_negative_numbers = true)]
    alpha: f64,
    /// Air density ρ in kg/m³, above 0 and at most 100.
    #[arg(long, value_name = "KG_M3", default_value_t = field::DEFAULT_DENSITY_KG_M3, allow_negative_numbers = true)]
    density: f64,
    /// Diameter in mm of the disk the force is integrated over, above 0 and
    /// at most 1000 (the paper's gauge disk is 15 mm).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 15.0,
        allow_negative_numbers = true
    )]
    disk: f64,
    /// Factor applied to the simulated force (e.g. measured / simulated),
    /// 0..=1e6.
    #[arg(
        long,
        value_name = "K",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    calibration: f64,
    /// Use the plain f64 loop instead of the fast path (slow; for checking).
    #[arg(long)]
    reference: bool,
    /// Render LM-S and LM-M (--foci, or 4 if --foci is 1) at radii 2-6 mm
    /// as one grid figure instead of a single stimulus.
    #[arg(long)]
    compare: bool,
}

fn positive(flag: &str, v: f64) -> Result<f64, InputError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(InputError::new(format!(
            "--{flag} must be a finite number > 0, got {v}"
        )))
    }
}

/// Refuses a simulation beyond [`limits::MAX_SIM_WORK`] (or the
/// reference loop's budget) before it starts, naming what to reduce.
fn check_work(
    points: usize,
    sources: usize,
    steps: usize,
    reference: bool,
) -> Result<(), InputError> {
    let work = points as f64 * sources as f64 * steps as f64;
    let max = if reference {
        limits::MAX_SIM_WORK_REFERENCE
    } else {
        limits::MAX_SIM_WORK
    };
    if work > max {
        return Err(InputError::new(format!(
            "{points} grid points × {sources} sources × {steps} steps = {} exceeds the limit {}{}; \
             use a coarser --plane-step, a smaller --plane-size or fewer steps",
            limits::show(work),
            limits::show(max),
            if reference { " for --reference" } else { "" }
        )));
    }
    Ok(())
}

/// Observation settings resolved from the flags.
struct View {
    size_mm: (f64, f64),
    step_mm: f64,
    center_mm: Option<[f64; 3]>,
    axes: Option<([f64; 3], [f64; 3])>,
    rad: Radiation,
    density: f64,
    disk_mm: f64,
    calibration: f64,
    reference: bool,
}

impl Args {
    fn view(&self) -> Result<View, InputError> {
        let size_mm = match &self.plane_size {
            None => (20.0, 20.0),
            Some(s) => {
                let v: Result<Vec<f64>, _> = s.split(',').map(|x| x.trim().parse()).collect();
                match v.as_deref() {
                    Ok([a]) => (positive("plane-size", *a)?, *a),
                    Ok([a, b]) => (positive("plane-size", *a)?, positive("plane-size", *b)?),
                    _ => {
                        return Err(InputError::new(format!(
                            "--plane-size takes S or W,H in mm, got `{s}`"
                        )));
                    }
                }
            }
        };
        let axes = match &self.plane_axes {
            None => None,
            Some(s) => {
                let v: Vec<f64> = s
                    .split([',', ';'])
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        InputError::new(format!(
                            "--plane-axes takes six numbers UX,UY,UZ,VX,VY,VZ, got `{s}`"
                        ))
                    })?;
                if v.len() != 6 {
                    return Err(InputError::new(format!(
                        "--plane-axes takes six numbers UX,UY,UZ,VX,VY,VZ, got `{s}`"
                    )));
                }
                Some(([v[0], v[1], v[2]], [v[3], v[4], v[5]]))
            }
        };
        let calibration = limits::in_range("--calibration", self.calibration, 0.0, 1e6, "")?;
        positive("alpha", self.alpha)?;
        positive("density", self.density)?;
        positive("disk", self.disk)?;
        limits::in_range("--alpha", self.alpha, 0.0, 2.0, "")?;
        limits::in_range("--density", self.density, 0.0, 100.0, "kg/m³")?;
        limits::in_range("--disk", self.disk, 0.0, 1000.0, "mm")?;
        limits::in_range("--plane-step", self.plane_step, 0.0, 1000.0, "mm")?;
        limits::in_range("--plane-size", size_mm.0, 0.0, 1000.0, "mm")?;
        limits::in_range("--plane-size", size_mm.1, 0.0, 1000.0, "mm")?;
        Ok(View {
            size_mm,
            step_mm: positive("plane-step", self.plane_step)?,
            center_mm: self
                .plane_center
                .as_deref()
                .map(|c| {
                    parse_vec3("plane-center", c)
                        .and_then(|v| limits::position_mm("--plane-center", v))
                })
                .transpose()?,
            axes,
            rad: Radiation {
                alpha: positive("alpha", self.alpha)?,
            },
            density: positive("density", self.density)?,
            disk_mm: positive("disk", self.disk)?,
            calibration,
            reference: self.reference,
        })
    }

    /// Run the subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        let view = self.view()?;
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("cannot create output directory {}", self.out.display()))?;
        if self.compare {
            return compare(&self.plan, &view, &self.out);
        }
        let plan = self.plan.plan()?;
        let sim = simulate_plan(&plan, &view)?;
        let r = self.plan.radius;
        write_outputs(&plan, &sim, &view, r, &self.out)?;
        println!("{}", sim.text_summary(&plan, r));
        println!("wrote {}", self.out.display());
        Ok(())
    }
}

/// A simulated stimulus.
struct Sim {
    plane: ObservationPlane,
    maps: FieldMaps,
    seconds: f64,
    force_step0_n: f64,
    force_mean_n: f64,
    clipped: bool,
    disk_mm: f64,
    path: &'static str,
}

fn simulate_plan(plan: &Plan, view: &View) -> anyhow::Result<Sim> {
    let model = field::model_for_scene(&plan.scene, view.density)?;
    let (u, v) = view
        .axes
        .unwrap_or((plan.scene.lm_plane.a, plan.scene.lm_plane.b));
    let plane = ObservationPlane {
        center_mm: view.center_mm.unwrap_or(plan.trajectory.center_mm),
        u,
        v,
        width_mm: view.size_mm.0,
        height_mm: view.size_mm.1,
        step_mm: view.step_mm,
    }
    .validated()
    .map_err(|e| InputError::new(e.to_string()))?;
    let seq = &plan.sequence;
    let steps = plan.trajectory.steps;
    check_work(
        plane.nu() * plane.nv(),
        plan.scene.transducer_count() * if plan.scene.reflector.is_some() { 2 } else { 1 },
        steps,
        view.reference,
    )?;
    let t0 = Instant::now();
    let maps = if view.reference {
        field::simulate_reference(&model, &plane, &seq.phases, steps, view.rad)
    } else {
        field::simulate(&model, &plane, &seq.phases, steps, view.rad)
    }
    .map_err(|e| InputError::new(e.to_string()))?;
    let seconds = t0.elapsed().as_secs_f64();
    // The disk sits on the LM centre, projected into the plane.
    let c = plane.project(plan.trajectory.center_mm);
    let (f0, clipped) = field::disk_force_n(&plane, &maps.pressure_pa, c, view.disk_mm);
    let (fm, _) = field::disk_force_n(&plane, &maps.mean_pressure_pa, c, view.disk_mm);
    Ok(Sim {
        plane,
        maps,
        seconds,
        force_step0_n: f0 * view.calibration,
        force_mean_n: fm * view.calibration,
        clipped,
        disk_mm: view.disk_mm,
        path: if view.reference {
            "f64 reference"
        } else {
            field::fast_path_isa()
        },
    })
}

/// The maps written, with file stem, title and unit.
fn map_list(m: &FieldMaps) -> [(&'static str, &'static str, &'static str, &[f64]); 5] {
    [
        (
            "mean_pressure",
            "Time-averaged radiation pressure",
            "Pa",
            &m.mean_pressure_pa,
        ),
        (
            "lm_power",
            "Radiation-pressure power at the LM frequency",
            "Pa²",
            &m.lm_power_pa2,
        ),
        (
            "pressure",
            "Radiation pressure, step 0",
            "Pa",
            &m.pressure_pa,
        ),
        (
            "amplitude",
            "Sound pressure amplitude, step 0",
            "Pa",
            &m.amplitude_pa,
        ),
        (
            "max_pressure",
            "Maximum radiation pressure over the cycle",
            "Pa",
            &m.max_pressure_pa,
        ),
    ]
}

/// Radial profile of `map` (row-major `nv × nu` on `plane`) around the
/// in-plane point `c_uv` (mm): the mean over rings `k·step ± step/2`, for
/// the rings that fit whole inside the grid.
fn radial_profile(
    plane: &ObservationPlane,
    nu: usize,
    nv: usize,
    map: &[f64],
    c_uv: [f64; 2],
) -> Vec<f64> {
    let step = plane.step_mm;
    let half_u = plane.u_mm(nu - 1) - c_uv[0].abs();
    let half_v = plane.v_mm(nv - 1) - c_uv[1].abs();
    let r_max = half_u.min(half_v).max(0.0);
    let bins = (r_max / step).floor() as usize + 1;
    let mut sum = vec![0.0; bins];
    let mut count = vec![0usize; bins];
    for iv in 0..nv {
        for iu in 0..nu {
            let du = plane.u_mm(iu) - c_uv[0];
            let dv = plane.v_mm(iv) - c_uv[1];
            let k = ((du * du + dv * dv).sqrt() / step).round() as usize;
            if k < bins {
                sum[k] += map[iv * nu + iu];
                count[k] += 1;
            }
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &n)| if n > 0 { s / n as f64 } else { 0.0 })
        .collect()
}

/// The radial profile of the cycle-mean radiation pressure around the LM
/// centre, with the two numbers that tell a ring from a spot: where the
/// profile peaks (also as a fraction of A) and the centre-to-orbit ratio
/// (profile at r = 0 over profile at r = A; below 1 for a ring).
fn radial_json(
    plane: &ObservationPlane,
    maps: &FieldMaps,
    center_mm: [f64; 3],
    radius_mm: f64,
) -> serde_json::Value {
    let c = plane.project(center_mm);
    let prof = radial_profile(plane, maps.nu, maps.nv, &maps.mean_pressure_pa, c);
    let step = plane.step_mm;
    let peak_k = field::peak(&prof).map(|(k, _)| k);
    let peak_r = peak_k.map(|k| k as f64 * step);
    let orbit_k = (radius_mm / step).round() as usize;
    let ratio = match prof.get(orbit_k) {
        Some(&o) if o > 0.0 && radius_mm > 0.0 => Some(prof[0] / o),
        _ => None,
    };
    json!({
        "map": "mean_pressure",
        "about": "mean over rings around the LM centre in the plane",
        "bin_mm": step,
        "profile_pa": prof,
        "peak_radius_mm": peak_r,
        "peak_radius_over_a": peak_r.filter(|_| radius_mm > 0.0).map(|r| r / radius_mm),
        "centre_to_orbit_ratio": ratio,
    })
}

/// Orbit (focus 0 over every step) and step-0 foci in plane coordinates.
fn overlay(plan: &Plan, plane: &ObservationPlane, disk_mm: f64) -> Overlay {
    let t = &plan.trajectory;
    let orbit = if t.steps > 1 {
        (0..t.steps)
            .map(|j| plane.project(t.foci_step(j)[0]))
            .collect()
    } else {
        Vec::new()
    };
    Overlay {
        orbit,
        foci: t.foci_step(0).iter().map(|&f| plane.project(f)).collect(),
        disk: Some((plane.project(t.center_mm), disk_mm)),
    }
}

impl Sim {
    fn peak_json(&self, map: &[f64]) -> serde_json::Value {
        match field::peak(map) {
            None => serde_json::Value::Null,
            Some((i, v)) => {
                let (iu, iv) = (i % self.maps.nu, i / self.maps.nu);
                json!({
                    "value": v,
                    "uv_mm": [self.plane.u_mm(iu), self.plane.v_mm(iv)],
                    "xyz_mm": self.plane.point(iu, iv),
                })
            }
        }
    }

    fn summary_json(&self, plan: &Plan, view: &View, radius_mm: f64) -> serde_json::Value {
        let t = &plan.trajectory;
        let p = &self.plane;
        let maps: serde_json::Map<String, serde_json::Value> = map_list(&self.maps)
            .iter()
            .map(|(stem, title, unit, m)| {
                (
                    stem.to_string(),
                    json!({
                        "title": title,
                        "unit": unit,
                        "npy": format!("{stem}.npy"),
                        "png": format!("{stem}.png"),
                        "peak": self.peak_json(m),
                    }),
                )
            })
            .collect();
        json!({
            "scene": plan.scene.name,
            "transducers": plan.scene.transducer_count(),
            "stimulus": {
                "radius_mm": radius_mm,
                "foci": t.foci,
                "steps": t.steps,
                "step_mm": t.step_mm,
                "dwell_s": t.dwell_s,
                "period_s": t.period_s,
                "center_mm": t.center_mm,
            },
            "model": {
                "p0_pa_mm": field::T4010A1_P0_PA_MM,
                "directivity": plan.scene.directivity,
                "sound_speed_m_s": plan.scene.sound_speed_m_s,
                "attenuation_np_per_m": plan.scene.attenuation_np_per_m,
                "density_kg_m3": view.density,
                "alpha": view.rad.alpha,
                "reflector": plan.scene.reflector.is_some(),
            },
            "plane": {
                "center_mm": p.center_mm,
                "u": p.u,
                "v": p.v,
                "width_mm": p.width_mm,
                "height_mm": p.height_mm,
                "step_mm": p.step_mm,
                "nu": self.maps.nu,
                "nv": self.maps.nv,
                "u_extent_mm": [p.u_mm(0), p.u_mm(self.maps.nu - 1)],
                "v_extent_mm": [p.v_mm(0), p.v_mm(self.maps.nv - 1)],
                "layout": "row-major, rows along v, columns along u",
            },
            "maps": maps,
            "force": {
                "disk_diameter_mm": self.disk_mm,
                "calibration": view.calibration,
                "step0_n": self.force_step0_n,
                "mean_n": self.force_mean_n,
                "disk_clipped": self.clipped,
            },
            "compute": { "seconds": self.seconds, "path": self.path },
            "radial": radial_json(p, &self.maps, t.center_mm, radius_mm),
        })
    }

    fn text_summary(&self, plan: &Plan, radius_mm: f64) -> String {
        let t = &plan.trajectory;
        let pk = |m: &[f64]| field::peak(m).map_or(0.0, |p| p.1);
        format!(
            "{} {}, A = {radius_mm} mm, N = {} steps, {} transducers; \
             grid {} × {} at {} mm in {:.3} s ({})\n\
             peak amplitude {:.0} Pa, radiation pressure {:.1} Pa (step 0), {:.1} Pa (cycle mean)\n\
             force on a {} mm disk: {:.4} N (step 0), {:.4} N (cycle mean){}",
            t.foci,
            if t.foci == 1 { "focus" } else { "foci" },
            t.steps,
            plan.scene.transducer_count(),
            self.maps.nu,
            self.maps.nv,
            self.plane.step_mm,
            self.seconds,
            self.path,
            pk(&self.maps.amplitude_pa),
            pk(&self.maps.pressure_pa),
            pk(&self.maps.mean_pressure_pa),
            self.disk_mm,
            self.force_step0_n,
            self.force_mean_n,
            if self.clipped {
                " (disk clipped by the grid)"
            } else {
                ""
            },
        )
    }
}

fn write_outputs(
    plan: &Plan,
    sim: &Sim,
    view: &View,
    radius_mm: f64,
    out: &Path,
) -> anyhow::Result<()> {
    let ov = overlay(plan, &sim.plane, sim.disk_mm);
    let kind = if plan.trajectory.foci > 1 {
        "LM-M"
    } else {
        "LM-S"
    };
    for (stem, title, unit, map) in map_list(&sim.maps) {
        let npy_path = out.join(format!("{stem}.npy"));
        npy::write_f64(&npy_path, sim.maps.nv, sim.maps.nu, map)
            .with_context(|| format!("cannot write {}", npy_path.display()))?;
        let panel = Panel {
            title: format!(
                "{title}: {kind}, A = {radius_mm} mm, N = {}",
                plan.trajectory.steps
            ),
            map,
            overlay: ov.clone(),
        };
        plot::heatmap(&out.join(format!("{stem}.png")), &sim.plane, &panel, unit)?;
    }
    let summary = sim.summary_json(plan, view, radius_mm);
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(&summary)? + "\n")
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Radii of the `--compare` grid (the paper's conditions).
const COMPARE_RADII_MM: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];

fn compare(args: &PlanArgs, view: &View, out: &Path) -> anyhow::Result<()> {
    let multi = if args.foci > 1 { args.foci } else { 4 };
    let mut sims = Vec::new();
    for (kind, foci) in [("LM-S", 1), ("LM-M", multi)] {
        for r in COMPARE_RADII_MM {
            let mut a = args.clone();
            a.radius = r;
            a.foci = foci;
            let plan = a
                .plan()
                .with_context(|| format!("planning {kind} at A = {r} mm"))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulation_work_is_bounded() {
        assert!(check_work(10_201, 996, 82, false).is_ok());
        let e = check_work(3_308_761, 996, 82, false).unwrap_err();
        assert!(e.0.contains("exceeds the limit 5e10"), "{e}");
        assert!(check_work(100_000, 996, 82, false).is_ok());
        assert!(check_work(100_000, 996, 82, true).is_err());
    }

    #[test]
    fn radial_profile_finds_a_ring_against_a_plain_loop() {
        let plane = ObservationPlane::lm_default([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
            .validated()
            .unwrap();
        let (nu, nv) = (plane.nu(), plane.nv());
        // A ring of radius 3 mm: exp(-(r - 3)²).
        let map: Vec<f64> = (0..nv)
            .flat_map(|iv| (0..nu).map(move |iu| (iu, iv)))
            .map(|(iu, iv)| {
                let r = plane.u_mm(iu).hypot(plane.v_mm(iv));
                (-(r - 3.0) * (r - 3.0)).exp()
            })
            .collect();
        let prof = radial_profile(&plane, nu, nv, &map, [0.0, 0.0]);
        assert_eq!(prof.len(), 51);
        let (k, _) = field::peak(&prof).unwrap();
        assert!((k as f64 * 0.2 - 3.0).abs() < 0.21, "peak bin {k}");
        assert!((prof[0] - (-9.0f64).exp()).abs() < 1e-12);
        // Bin 15 (3 mm) is the plain mean of the points that round to it.
        let (mut s, mut n) = (0.0, 0);
        for iv in 0..nv {
            for iu in 0..nu {
                if (plane.u_mm(iu).hypot(plane.v_mm(iv)) / 0.2).round() as usize == 15 {
                    s += map[iv * nu + iu];
                    n += 1;
                }
            }
        }
        assert!((prof[15] - s / n as f64).abs() < 1e-12);
    }
}
