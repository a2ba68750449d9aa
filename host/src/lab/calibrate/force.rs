//! `lmhost calibrate force`: the factor that makes the simulated force of
//! a static focus equal a measured one.
//!
//! The paper measured 0.022 N for a static focus at the LM centre with a
//! force gauge under a 15 mm acrylic disk facing the wave. Here the same
//! focus is simulated with the scene's model, uncalibrated, and the force
//! on a disk of that size in the LM plane (which faces the wave in the
//! paper's scene) integrated; measured / simulated is the scene's
//! `[calibration] pressure_scale`, which every map and force then carries
//! ([`crate::field::FieldMaps::calibrate`]).

use serde::Serialize;

use crate::error::InputError;
use crate::field::study::{View, simulate_plan};
use crate::geom::Vec3;
use crate::limits::show;
use crate::plan::scene::LmPlane;
use crate::plan::scene::{MAX_PRESSURE_SCALE, MIN_PRESSURE_SCALE, Scene};
use crate::plan::sequence::{Plan, Synthesis};
use crate::plan::trajectory::Cycle;

/// Smallest force `--measured` takes (N): 0.1 mN, a force gauge's
/// resolution and 1/200 of the paper's 0.022 N. Below it the reading is
/// noise, and the scale derived from it would silence every map.
pub const MIN_MEASURED_N: f64 = 1e-4;
/// Largest force `--measured` takes (N): well above any array's.
pub const MAX_MEASURED_N: f64 = 100.0;
/// Grid step of the simulation (mm).
const STEP_MM: f64 = 0.25;

/// A force calibration and what it was derived from.
#[derive(Debug, Clone, Serialize)]
pub struct ForceCalibration {
    /// The measured force (N).
    pub measured_n: f64,
    /// The uncalibrated simulated force of the same focus (N).
    pub simulated_n: f64,
    /// measured / simulated.
    pub pressure_scale: f64,
    /// Gauge disk diameter (mm).
    pub disk_mm: f64,
    /// Where the focus was (mm, scene coordinates).
    pub center_mm: Vec3,
}

impl ForceCalibration {
    /// The `[calibration]` table's keys, with a comment saying where they
    /// came from.
    pub fn table(&self) -> String {
        use super::toml_f64 as f;
        let c = self.center_mm;
        format!(
            "# lmhost calibrate force: a static focus at ({}, {}, {}) mm measured {} N on a\n\
             # {} mm disk; the model gives {:.5} N. Every simulated pressure and force is\n\
             # multiplied by pressure_scale (amplitudes by its square root).\n\
             pressure_scale = {}\nmeasured_n = {}\nsimulated_n = {}\ndisk_mm = {}\n",
            show(c[0]),
            show(c[1]),
            show(c[2]),
            show(self.measured_n),
            show(self.disk_mm),
            self.simulated_n,
            f(self.pressure_scale),
            f(self.measured_n),
            f(self.simulated_n),
            f(self.disk_mm),
        )
    }
}

/// Simulates a static focus at `center_mm` (default: the scene's LM
/// centre) without calibration and derives the factor that makes its force
/// on a `disk_mm` disk equal `measured_n`.
pub fn calibrate(
    scene: &Scene,
    measured_n: f64,
    disk_mm: f64,
    center_mm: Option<Vec3>,
) -> anyhow::Result<ForceCalibration> {
    if !(measured_n.is_finite() && (MIN_MEASURED_N..=MAX_MEASURED_N).contains(&measured_n)) {
        return Err(InputError::new(format!(
            "--measured must be a force of {MIN_MEASURED_N}..={MAX_MEASURED_N} N, got {} N",
            show(measured_n)
        ))
        .into());
    }
    if !(disk_mm.is_finite() && disk_mm > 0.0 && disk_mm <= 100.0) {
        return Err(InputError::new(format!(
            "--disk must be a diameter in mm, > 0 and at most 100, got {}",
            show(disk_mm)
        ))
        .into());
    }
    let center_mm = center_mm.unwrap_or(scene.center_mm);
    let p = Cycle::static_focus().at(center_mm, LmPlane::default());
    let plan = Plan::new(scene.clone(), &p, &Synthesis::Linear)?;
    let side = disk_mm + 2.0;
    let view = View {
        size_mm: (side, side),
        step_mm: STEP_MM,
        disk_mm,
        calibration: Some(1.0),
        ..View::default()
    };
    let sim = simulate_plan(&plan, &view)?;
    let simulated_n = sim.force_step0_n;
    if !(simulated_n.is_finite() && simulated_n > 0.0) {
        return Err(InputError::new(format!(
            "the simulated focus at {center_mm:?} mm gives no force ({simulated_n} N): is it in front of the array?"
        ))
        .into());
    }
    let pressure_scale = measured_n / simulated_n;
    if !(MIN_PRESSURE_SCALE..=MAX_PRESSURE_SCALE).contains(&pressure_scale) {
        return Err(InputError::new(format!(
            "measured / simulated = {} N / {} N = {} is outside {MIN_PRESSURE_SCALE:e}..={MAX_PRESSURE_SCALE:e}: \
             check --measured, --disk and the scene",
            show(measured_n),
            show(simulated_n),
            show(pressure_scale)
        ))
        .into());
    }
    Ok(ForceCalibration {
        measured_n,
        simulated_n,
        pressure_scale,
        disk_mm,
        center_mm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_with(text_extra: &str) -> Scene {
        let base =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml"))
                .unwrap();
        Scene::from_toml(&format!("{base}\n{text_extra}"), "paper.toml").unwrap()
    }

    /// The paper's measurement: the calibrated scene's static focus gives
    /// 0.022 N, every map scales as the calibration says, and a scene
    /// without `[calibration]` is the model's.
    #[test]
    fn calibrated_static_focus_gives_the_measured_force_and_maps_scale_consistently() {
        let raw = scene_with("");
        let cal = calibrate(&raw, 0.022, 15.0, None).unwrap();
        // The model is several times stronger than the rig was.
        assert!(
            cal.simulated_n > 0.03 && cal.pressure_scale < 0.8,
            "{cal:?}"
        );
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml"))
                .unwrap();
        let updated =
            super::super::with_table(&text, "calibration", &cal.table(), "paper.toml").unwrap();
        let scene = Scene::from_toml(&updated, "paper.toml").unwrap();
        let c = scene.calibration.unwrap();
        assert_eq!(c.pressure_scale, cal.pressure_scale, "written exactly");
        // Calibrated again: the force now is the measured one.
        let again = calibrate(&scene, 0.022, 15.0, None).unwrap();
        assert!(
            (again.simulated_n - cal.simulated_n).abs() < 1e-12,
            "the derivation ignores the calibration"
        );
        let p = Cycle::static_focus().at(scene.center_mm, LmPlane::default());
        let view = View {
            size_mm: (17.0, 17.0),
            step_mm: STEP_MM,
            ..View::default()
        };
        let sim_cal = simulate_plan(
            &Plan::new(scene.clone(), &p, &Synthesis::Linear).unwrap(),
            &view,
        )
        .unwrap();
        assert!(
            (sim_cal.force_step0_n - 0.022).abs() < 1e-9,
            "{} N",
            sim_cal.force_step0_n
        );
        let sim_raw = simulate_plan(
            &Plan::new(raw.clone(), &p, &Synthesis::Linear).unwrap(),
            &view,
        )
        .unwrap();
        assert!((sim_raw.force_step0_n - cal.simulated_n).abs() < 1e-12);
        // Every map: pressures ×k, power ×k², amplitude ×√k.
        let k = cal.pressure_scale;
        let (a, b) = (&sim_raw.maps, &sim_cal.maps);
        let close = |x: &[f64], y: &[f64], f: f64| {
            x.iter()
                .zip(y)
                .all(|(x, y)| (x * f - y).abs() <= 1e-9 * (x * f).abs().max(1e-12))
        };
        assert!(close(&a.pressure_pa, &b.pressure_pa, k));
        assert!(close(&a.mean_pressure_pa, &b.mean_pressure_pa, k));
        assert!(close(&a.max_pressure_pa, &b.max_pressure_pa, k));
        assert!(close(&a.lm_power_pa2, &b.lm_power_pa2, k * k));
        assert!(close(&a.amplitude_pa, &b.amplitude_pa, k.sqrt()));
        // An explicit factor replaces the scene's; it does not multiply.
        let view2 = View {
            calibration: Some(2.0),
            ..view
        };
        let sim2 =
            simulate_plan(&Plan::new(scene, &p, &Synthesis::Linear).unwrap(), &view2).unwrap();
        assert!((sim2.force_step0_n - 2.0 * cal.simulated_n).abs() < 1e-9);
    }

    #[test]
    fn bad_measurements_and_calibrations_are_one_line_errors() {
        let raw = scene_with("");
        for (m, d) in [
            (0.0, 15.0),
            (1e-300, 15.0),
            (5e-5, 15.0),
            (-0.02, 15.0),
            (f64::NAN, 15.0),
            (1e3, 15.0),
            (0.022, 0.0),
            (0.022, 1e3),
        ] {
            let e = calibrate(&raw, m, d, None).unwrap_err().to_string();
            assert!(
                !e.contains('\n') && (e.contains("--measured") || e.contains("--disk")),
                "{e}"
            );
        }
        for bad in [
            "pressure_scale = 0",
            "pressure_scale = -1",
            "pressure_scale = nan",
            "pressure_scale = 2e6",
            "pressure_scale = 1\nmeasured_n = -3",
            "scale = 1",
        ] {
            let base = std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../scenes/paper.toml"
            ))
            .unwrap();
            let e = Scene::from_toml(&format!("{base}\n[calibration]\n{bad}\n"), "s.toml")
                .unwrap_err()
                .0;
            assert!(
                e.contains("calibration") || e.contains("scale"),
                "{bad}: {e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
