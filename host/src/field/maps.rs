//! Maps of one LM cycle: per-point statistics of the radiation pressure
//! over the cycle's steps, reduced to [`FieldMaps`], and [`simulate`], the
//! fast path that fills them.

use super::stats::Stats;
use super::{FieldError, FieldModel, ObservationPlane, kernel};

/// Default radiation-pressure coefficient α (2: a perfect reflector).
pub const DEFAULT_RADIATION_ALPHA: f64 = 2.0;

/// Maps of one LM cycle on an [`ObservationPlane`], row-major by `v`.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldMaps {
    /// Columns.
    pub nu: usize,
    /// Rows.
    pub nv: usize,
    /// Steps in the cycle.
    pub steps: usize,
    /// Pressure amplitude at step 0 (Pa, peak).
    pub amplitude_pa: Vec<f64>,
    /// Radiation pressure at step 0 (Pa).
    pub pressure_pa: Vec<f64>,
    /// Radiation pressure averaged over the cycle (Pa).
    pub mean_pressure_pa: Vec<f64>,
    /// Maximum radiation pressure over the cycle (Pa).
    pub max_pressure_pa: Vec<f64>,
    /// Power of the radiation pressure at the LM frequency (Pa²): the mean
    /// square `A₁²/2` of its bin-1 sinusoid, `A₁ = 2 |X₁| / N` with
    /// `X₁ = Σₛ P(s) e^{−j2πs/N}` (`A₁ = |X₁| / N` for N = 2; 0 for N = 1).
    pub lm_power_pa2: Vec<f64>,
}

impl FieldMaps {
    /// Applies a force calibration `k` (measured / simulated radiation
    /// force): radiation pressure ×k, its power at the LM frequency ×k²,
    /// the sound-pressure amplitude ×√k (radiation pressure goes with the
    /// amplitude squared).
    pub fn calibrate(&mut self, k: f64) {
        if k == 1.0 {
            return;
        }
        let (a, k2) = (k.sqrt(), k * k);
        self.amplitude_pa.iter_mut().for_each(|v| *v *= a);
        for m in [
            &mut self.pressure_pa,
            &mut self.mean_pressure_pa,
            &mut self.max_pressure_pa,
        ] {
            m.iter_mut().for_each(|v| *v *= k);
        }
        self.lm_power_pa2.iter_mut().for_each(|v| *v *= k2);
    }
}

/// Radiation-pressure settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Radiation {
    /// Coefficient α of `α |p|² / (2 ρ c²)`.
    pub alpha: f64,
}

impl Default for Radiation {
    fn default() -> Self {
        Self {
            alpha: DEFAULT_RADIATION_ALPHA,
        }
    }
}

pub(super) fn check_inputs(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<ObservationPlane, FieldError> {
    let t = model.transducers();
    if steps == 0 || phases.len() != steps.saturating_mul(t) {
        return Err(FieldError::BadSequence {
            got: phases.len(),
            steps,
            transducers: t,
        });
    }
    if !(rad.alpha.is_finite() && rad.alpha > 0.0) {
        return Err(FieldError::BadAlpha(rad.alpha));
    }
    plane.validated()
}

pub(super) fn finish(plane: &ObservationPlane, steps: usize, stats: &[Stats]) -> FieldMaps {
    let n = steps as f64;
    let scale = match steps {
        1 => 0.0,
        2 => 1.0 / n,
        _ => 2.0 / n,
    };
    FieldMaps {
        nu: plane.nu(),
        nv: plane.nv(),
        steps,
        amplitude_pa: stats.iter().map(|s| s.amp0).collect(),
        pressure_pa: stats.iter().map(|s| s.p0).collect(),
        mean_pressure_pa: stats.iter().map(|s| s.sum / n).collect(),
        max_pressure_pa: stats.iter().map(|s| s.max).collect(),
        lm_power_pa2: stats
            .iter()
            .map(|s| {
                let a1 = scale * s.x1_re.hypot(s.x1_im);
                a1 * a1 / 2.0
            })
            .collect(),
    }
}

/// Maps of a phase sequence (step-major, `steps × transducers` bytes): the
/// fast path. Propagation terms are computed once per point block in f32
/// (phase reduced to turns in f64 first), multiplied by the drive matrix of
/// all steps, and reduced to statistics on the fly; the grid is split over
/// two threads. Agrees with [`simulate_reference`](super::simulate_reference) to ~1e-5 relative at the
/// peak (checked in tests and in `lmhost bench`).
pub fn simulate(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<FieldMaps, FieldError> {
    let plane = check_inputs(model, plane, phases, steps, rad)?;
    let stats = kernel::run(
        model,
        &plane,
        phases,
        steps,
        model.radiation_factor(rad.alpha),
    );
    Ok(finish(&plane, steps, &stats))
}
