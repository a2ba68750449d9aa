//! Simulating a planned stimulus on an observation plane: the work limit,
//! the maps, the force on a disk, the radial profile that tells a ring from
//! a spot, the JSON and text summaries and the files `lmhost simulate`
//! writes. The LM-S/LM-M comparison grid is [`super::compare`].

use std::path::Path;
use std::time::Instant;

use serde_json::json;

use crate::error::InputError;
use crate::field::plot::{self, Figure, Labels, Overlay, Panel};
use crate::field::{self, FieldMaps, ObservationPlane, Radiation};
use crate::limits;
use crate::npy;
use crate::plan::sequence::Plan;

/// Lowest medium density (`--density`), kg/m³: air at about 50 km.
pub const MIN_DENSITY_KG_M3: f64 = 1e-3;

/// Observation settings: the plane, the radiation model and the force disk.
pub struct View {
    /// Plane width and height (mm).
    pub size_mm: (f64, f64),
    /// Grid step (mm).
    pub step_mm: f64,
    /// Plane centre (mm); `None`: the LM centre.
    pub center_mm: Option<[f64; 3]>,
    /// Plane axes u, v; `None`: the scene's LM plane a, b.
    pub axes: Option<([f64; 3], [f64; 3])>,
    /// Radiation-pressure model.
    pub rad: Radiation,
    /// Air density (kg/m³).
    pub density: f64,
    /// Diameter of the force disk (mm).
    pub disk_mm: f64,
    /// Factor on the simulated radiation pressure in place of the scene's
    /// `[calibration]` (`None`: the scene's, or 1 without one).
    pub calibration: Option<f64>,
    /// Use the plain f64 loop instead of the fast path.
    pub reference: bool,
}

/// Default observation plane width and height (mm).
pub const PLANE_SIZE_MM: f64 = 20.0;
/// Default observation grid step (mm).
pub const PLANE_STEP_MM: f64 = 0.2;
/// Default force-disk diameter (mm): the paper's gauge disk.
pub const DISK_MM: f64 = 15.0;

impl View {
    /// Checks every number against the limits `lmhost simulate` documents
    /// (the messages name its flags); the plane's own checks and the work
    /// limit come later, in [`simulate_plan`].
    pub fn check(&self) -> Result<(), crate::InputError> {
        use crate::limits::in_range;
        let positive = |flag: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(crate::InputError::new(format!(
                    "--{flag} must be a finite number > 0, got {v}"
                )))
            }
        };
        positive("plane-size", self.size_mm.0)?;
        positive("plane-size", self.size_mm.1)?;
        if let Some(k) = self.calibration {
            positive("calibration", k)?;
            in_range(
                "--calibration",
                k,
                crate::plan::scene::MIN_PRESSURE_SCALE,
                crate::plan::scene::MAX_PRESSURE_SCALE,
                "",
            )?;
        }
        positive("alpha", self.rad.alpha)?;
        positive("density", self.density)?;
        positive("disk", self.disk_mm)?;
        crate::limits::in_range_above("--alpha", self.rad.alpha, 0.0, 2.0, "")?;
        // From a thin gas up: the force divides by it, and a density of
        // 1e-320 gave a force of inf N without a word.
        in_range("--density", self.density, MIN_DENSITY_KG_M3, 100.0, "kg/m³")?;
        crate::limits::in_range_above("--disk", self.disk_mm, 0.0, 1000.0, "mm")?;
        crate::limits::in_range_above("--plane-step", self.step_mm, 0.0, 1000.0, "mm")?;
        crate::limits::in_range_above("--plane-size", self.size_mm.0, 0.0, 1000.0, "mm")?;
        crate::limits::in_range_above("--plane-size", self.size_mm.1, 0.0, 1000.0, "mm")?;
        positive("plane-step", self.step_mm)?;
        if let Some(c) = self.center_mm {
            crate::limits::position_mm("--plane-center", c)?;
        }
        Ok(())
    }
}

impl Default for View {
    /// A 20 mm square at 0.2 mm on the LM plane about the LM centre, the
    /// paper's 15 mm force disk, α = 2, air at 20 °C, the scene's
    /// calibration.
    fn default() -> Self {
        Self {
            size_mm: (PLANE_SIZE_MM, PLANE_SIZE_MM),
            step_mm: PLANE_STEP_MM,
            center_mm: None,
            axes: None,
            rad: Radiation::default(),
            density: super::DEFAULT_DENSITY_KG_M3,
            disk_mm: DISK_MM,
            calibration: None,
            reference: false,
        }
    }
}

/// Refuses a simulation beyond [`limits::MAX_SIM_WORK`] (or the
/// reference loop's budget) before it starts, naming what to reduce.
pub fn check_work(
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

/// A simulated stimulus.
pub struct Sim {
    /// The observation plane, validated.
    pub plane: ObservationPlane,
    /// The cycle maps.
    pub maps: FieldMaps,
    /// Compute time (s).
    pub seconds: f64,
    /// Force on the disk at step 0 (N), calibrated.
    pub force_step0_n: f64,
    /// Cycle-mean force on the disk (N), calibrated.
    pub force_mean_n: f64,
    /// Whether the grid clips the disk.
    pub clipped: bool,
    /// Disk diameter (mm).
    pub disk_mm: f64,
    /// Which kernel computed the maps.
    pub path: &'static str,
    /// The factor the maps and forces carry, and where it came from.
    pub calibration: (f64, CalibrationSource),
    /// What the plan's amplitude modulation adds (the maps above carry it).
    pub am: Option<field::am::AmMaps>,
}

/// Where a simulation's calibration factor came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationSource {
    /// No calibration: the model's Pa.
    None,
    /// The scene's `[calibration]`.
    Scene,
    /// `--calibration` (or the Python `calibration=`), replacing the scene's.
    Flag,
}

impl CalibrationSource {
    /// Its name in summaries.
    pub fn name(self) -> &'static str {
        match self {
            CalibrationSource::None => "none",
            CalibrationSource::Scene => "scene",
            CalibrationSource::Flag => "--calibration",
        }
    }
}

/// The calibration factor for `scene` seen through `view`: the view's
/// override, else the scene's `[calibration]`, else 1.
pub fn calibration_for(scene: &crate::plan::scene::Scene, view: &View) -> (f64, CalibrationSource) {
    match (view.calibration, &scene.calibration) {
        (Some(k), _) => (k, CalibrationSource::Flag),
        (None, Some(c)) => (c.pressure_scale, CalibrationSource::Scene),
        (None, None) => (1.0, CalibrationSource::None),
    }
}

/// The one intensity rule of a simulation: it models full output (its
/// maps scale with the drive amplitude the driver makes of an intensity),
/// so a stimulus of another `intensity` (0-255, 255 = full) is refused as
/// bad input rather than simulated as if it were full.
pub fn check_full_output(intensity: u8) -> Result<(), crate::InputError> {
    if intensity == u8::MAX {
        return Ok(());
    }
    Err(crate::InputError::new(format!(
        "{} applies to devices: simulate models full output \
         (its maps scale with the drive amplitude the driver makes of it)",
        crate::plan::stimulus::intensity_words(intensity)
    )))
}

/// Simulates `plan` on the plane `view` describes, after the work check;
/// a plan not at full intensity is refused ([`check_full_output`]).
pub fn simulate_plan(plan: &Plan, view: &View) -> anyhow::Result<Sim> {
    check_full_output(plan.sequence.header.intensity)?;
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
    // The one place the calibration is applied: every map, so the forces
    // integrated from them below are calibrated too.
    let calibration = calibration_for(&plan.scene, view);
    let mut maps = maps;
    maps.calibrate(calibration.0);
    let am = plan.am.as_ref().map(|a| field::am::apply(&mut maps, a));
    let seconds = t0.elapsed().as_secs_f64();
    // The disk sits on the LM centre, projected into the plane.
    let c = plane.project(plan.trajectory.center_mm);
    let (f0, clipped) = field::disk_force_n(&plane, &maps.pressure_pa, c, view.disk_mm);
    let (fm, _) = field::disk_force_n(&plane, &maps.mean_pressure_pa, c, view.disk_mm);
    Ok(Sim {
        plane,
        maps,
        seconds,
        force_step0_n: f0,
        force_mean_n: fm,
        clipped,
        disk_mm: view.disk_mm,
        path: if view.reference {
            "f64 reference"
        } else {
            field::fast_path_isa()
        },
        calibration,
        am,
    })
}

/// A written map: file stem, title, unit, colour-bar label (short, with
/// the unit) and the map.
pub type MapEntry<'a> = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'a [f64],
);

/// The maps written, with file stem, title, unit and colour-bar label.
pub fn map_list(m: &FieldMaps) -> [MapEntry<'_>; 5] {
    [
        (
            "mean_pressure",
            "Time-averaged radiation pressure",
            "Pa",
            "mean rad. pressure (Pa)",
            &m.mean_pressure_pa,
        ),
        (
            "lm_power",
            "Radiation-pressure power at the LM frequency",
            "Pa²",
            "power at f_LM (Pa²)",
            &m.lm_power_pa2,
        ),
        (
            "pressure",
            "Radiation pressure, step 0",
            "Pa",
            "rad. pressure (Pa)",
            &m.pressure_pa,
        ),
        (
            "amplitude",
            "Sound pressure amplitude, step 0",
            "Pa",
            "amplitude (Pa)",
            &m.amplitude_pa,
        ),
        (
            "max_pressure",
            "Maximum radiation pressure over the cycle",
            "Pa",
            "max rad. pressure (Pa)",
            &m.max_pressure_pa,
        ),
    ]
}

/// Radial profile of `map` (row-major `nv × nu` on `plane`) around the
/// in-plane point `c_uv` (mm): the mean over rings `k·step ± step/2`, for
/// the rings that fit whole inside the grid.
pub fn radial_profile(
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
pub fn radial_json(
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

/// A figure's axis names (the scene's LM plane axes where the plane lies
/// along them) and the gauge disk; the caller adds the rest.
pub fn labels(plan: &Plan, plane: &ObservationPlane, disk_mm: f64) -> Labels {
    let lm = &plan.scene.lm_plane;
    let (x, y) = plot::axis_names(plane, lm.a, lm.b);
    Labels {
        x,
        y,
        disk_mm: Some(disk_mm),
        ..Labels::default()
    }
}

/// Orbit (focus 0 over every step) and step-0 foci in plane coordinates.
pub fn overlay(plan: &Plan, plane: &ObservationPlane, disk_mm: f64) -> Overlay {
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
    /// The peak of `map` with its plane and scene coordinates, or null.
    pub fn peak_json(&self, map: &[f64]) -> serde_json::Value {
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

    /// The JSON summary: stimulus, model, plane, maps, force, compute, radial profile.
    pub fn summary_json(&self, plan: &Plan, view: &View, radius_mm: f64) -> serde_json::Value {
        let t = &plan.trajectory;
        let p = &self.plane;
        let maps: serde_json::Map<String, serde_json::Value> = map_list(&self.maps)
            .iter()
            .map(|(stem, title, unit, _, m)| {
                (
                    stem.to_string(),
                    json!({
                        "title": title,
                        "unit": unit,
                        "npy": format!("{stem}.npy"),
                        "png": format!("{stem}.png"),
                        "svg": format!("{stem}.svg"),
                        "peak": self.peak_json(m),
                    }),
                )
            })
            .collect();
        json!({
            "scene": plan.scene.name,
            "transducers": plan.scene.transducer_count(),
            "stimulus": {
                "path": t.path.map(|p| p.name()),
                "half_extent_mm": t.path.map(|p| p.half_extent_mm(radius_mm)),
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
                "calibration": self.calibration.0,
                "calibration_source": self.calibration.1.name(),
                "step0_n": self.force_step0_n,
                "mean_n": self.force_mean_n,
                "disk_clipped": self.clipped,
            },
            "compute": { "seconds": self.seconds, "path": self.path },
            "radial": radial_json(p, &self.maps, t.center_mm, radius_mm),
            "mean_pressure_half_peak_extent_mm": field::half_peak_extent_mm(p, &self.maps.mean_pressure_pa)
                .map(|(u, v)| json!({ "u": u, "v": v })),
            "am": self.am.as_ref().map(|a| a.summary_json(self.force_mean_n / a.mean_square)),
        })
    }

    /// The three-line summary `lmhost simulate` prints.
    pub fn text_summary(&self, plan: &Plan, radius_mm: f64) -> String {
        let t = &plan.trajectory;
        use crate::limits::Num as N;
        let pk = |m: &[f64]| field::peak(m).map_or(0.0, |p| p.1);
        let shape = match t.path {
            Some(p) if p != crate::plan::path::Path::Circle => {
                let (a, b) = p.half_extent_mm(radius_mm);
                format!("{} ±{} × ±{}", p.name(), N(a), N(b))
            }
            _ => format!("A = {}", N(radius_mm)),
        };
        format!(
            "{} {}, {shape} mm, N = {} steps, {} transducers; \
             grid {} × {} at {} mm in {:.3} s ({})\n\
             peak amplitude {:.0} Pa, radiation pressure {:.1} Pa (step 0), {:.1} Pa (cycle mean)\n\
             force on a {} mm disk: {:.4} N (step 0), {:.4} N (cycle mean){}{}",
            t.foci,
            if t.foci == 1 { "focus" } else { "foci" },
            t.steps,
            plan.scene.transducer_count(),
            self.maps.nu,
            self.maps.nv,
            N(self.plane.step_mm),
            self.seconds,
            self.path,
            N(pk(&self.maps.amplitude_pa)),
            N(pk(&self.maps.pressure_pa)),
            N(pk(&self.maps.mean_pressure_pa)),
            N(self.disk_mm),
            N(self.force_step0_n),
            N(self.force_mean_n),
            if self.clipped {
                " (disk clipped by the grid)"
            } else {
                ""
            },
            match self.calibration {
                (_, CalibrationSource::None) => String::new(),
                (k, s) => format!(
                    "\ncalibrated: pressures and forces × {} ({})",
                    N(k),
                    s.name()
                ),
            },
        ) + &self.am.as_ref().map_or(String::new(), |a| {
            format!(
                "\nAM {} at {} Hz (played at {:.2} Hz), depth {}: mean pressure × {:.3}, power at the AM frequency up to {:.1} Pa²",
                a.am.shape.name(),
                N(a.am.freq_hz),
                a.am.realised_freq_hz(),
                N(a.am.depth),
                a.mean_square,
                pk(&a.power_pa2)
            )
        })
    }
}

/// Writes one `.npy` and one figure per map (`fig`'s formats) and
/// `summary.json` into `out`.
pub fn write_outputs(
    plan: &Plan,
    sim: &Sim,
    view: &View,
    radius_mm: f64,
    fig: &Figure,
    out: &Path,
) -> anyhow::Result<()> {
    let ov = overlay(plan, &sim.plane, sim.disk_mm);
    for (stem, _, _, colorbar, map) in map_list(&sim.maps) {
        let npy_path = out.join(format!("{stem}.npy"));
        npy::write_f64(&npy_path, sim.maps.nv, sim.maps.nu, map)?;
        let panel = Panel {
            map,
            overlay: ov.clone(),
        };
        let labels = Labels {
            colorbar: colorbar.into(),
            ..labels(plan, &sim.plane, sim.disk_mm)
        };
        plot::heatmap(&out.join(stem), &sim.plane, &panel, &labels, fig)?;
    }
    if let Some(am) = &sim.am {
        let npy_path = out.join("am_power.npy");
        npy::write_f64(&npy_path, sim.maps.nv, sim.maps.nu, &am.power_pa2)?;
        let panel = Panel {
            map: &am.power_pa2,
            overlay: ov.clone(),
        };
        let labels = Labels {
            colorbar: "AM power (Pa²)".into(),
            ..labels(plan, &sim.plane, sim.disk_mm)
        };
        plot::heatmap(&out.join("am_power"), &sim.plane, &panel, &labels, fig)?;
    }
    let summary = sim.summary_json(plan, view, radius_mm);
    let path = out.join("summary.json");
    // Last: a summary.json exists only when every file it names was written.
    crate::files::write_whole(
        &path,
        (serde_json::to_string_pretty(&summary)? + "\n").as_bytes(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field;

    #[test]
    fn only_full_output_is_simulated() {
        assert!(check_full_output(255).is_ok());
        let e = check_full_output(128).unwrap_err().to_string();
        assert!(e.contains("128/255") && e.contains("full output"), "{e}");
        // The plan's own intensity decides, wherever the call comes from.
        let half = crate::plan::stimulus::Stimulus {
            intensity: 0.5,
            ..Default::default()
        }
        .plan_for(
            &crate::plan::target::Target::Lm,
            crate::plan::scene::Scene::default(),
        )
        .unwrap()
        .plan;
        let view = View {
            size_mm: (2.0, 2.0),
            step_mm: 1.0,
            center_mm: None,
            axes: None,
            rad: Radiation::default(),
            density: 1.0,
            disk_mm: 1.0,
            calibration: None,
            reference: false,
        };
        let e = simulate_plan(&half, &view).err().unwrap();
        assert!(e.chain().any(|c| c.is::<InputError>()), "{e:#}");
    }

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
