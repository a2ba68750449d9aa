//! The `field` section of `lmhost bench`: fast path against the plain f64
//! loop on the target case, time and relative error.

use serde::Serialize;

use super::{Options, Section, time_per_call};
use crate::field::{
    DEFAULT_DENSITY_KG_M3, FieldMaps, ObservationPlane, Radiation, fast_path_isa, model_for_scene,
    peak, simulate, simulate_reference,
};
use crate::plan::scene::Scene;
use crate::plan::sequence::{Sequence, Synthesis};
use crate::plan::trajectory::{LmParams, Trajectory};

/// Figures of the field section.
#[derive(Debug, Clone, Serialize)]
pub struct FieldFigures {
    /// What was simulated.
    pub case: String,
    /// Grid points.
    pub points: usize,
    /// Transducers.
    pub transducers: usize,
    /// Steps in the cycle.
    pub steps: usize,
    /// Instruction set of the fast path.
    pub isa: String,
    /// Fast path, whole grid, all maps (s, median, 2 threads).
    pub fast_s: f64,
    /// Plain f64 loop, seconds per grid point (median, one thread).
    pub reference_s_per_point: f64,
    /// Plain f64 loop extrapolated to the whole grid (s).
    pub reference_full_s: f64,
    /// reference_full_s / fast_s.
    pub speedup: f64,
    /// Points of the central sub-grid where both paths were compared.
    pub compared_points: usize,
    /// |fast − f64| / f64 at the peak of the time-averaged map.
    pub rel_err_peak_mean: f64,
    /// Same for the LM-frequency power map.
    pub rel_err_peak_lm_power: f64,
    /// Same for the step-0 radiation pressure map.
    pub rel_err_peak_step0: f64,
    /// Largest |fast − f64| anywhere on the sub-grid, over the peak, of any map.
    pub max_err_over_peak: f64,
}

fn rel_at_peak(fast: &[f64], reference: &[f64]) -> f64 {
    peak(reference).map_or(0.0, |(i, p)| (fast[i] - p).abs() / p)
}

fn max_over_peak(fast: &FieldMaps, reference: &FieldMaps) -> f64 {
    let pairs = [
        (&fast.mean_pressure_pa, &reference.mean_pressure_pa),
        (&fast.lm_power_pa2, &reference.lm_power_pa2),
        (&fast.pressure_pa, &reference.pressure_pa),
        (&fast.max_pressure_pa, &reference.max_pressure_pa),
        (&fast.amplitude_pa, &reference.amplitude_pa),
    ];
    pairs
        .iter()
        .map(|(a, b)| {
            let p = peak(b).map_or(1.0, |x| x.1);
            a.iter()
                .zip(b.iter())
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
                / p
        })
        .fold(0.0, f64::max)
}

/// The `field` bench section: LM-M, A = 3 mm, 4 foci, N = 82 on the
/// built-in 996-transducer array, maps on the default 101 × 101 LM plane.
pub fn section(opts: &Options) -> anyhow::Result<Section> {
    let scene = Scene::default();
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.foci = 4;
    let traj = Trajectory::plan(&p, &scene)?;
    let seq = Sequence::synthesize(&scene, &traj, &Synthesis::Linear)?;
    let model = model_for_scene(&scene, DEFAULT_DENSITY_KG_M3)?;
    let plane = ObservationPlane::lm_default(traj.center_mm, scene.lm_plane.a, scene.lm_plane.b);
    let rad = Radiation::default();
    let steps = traj.steps;
    let run_fast = |pl: &ObservationPlane| simulate(&model, pl, &seq.phases, steps, rad);
    let run_ref = |pl: &ObservationPlane| simulate_reference(&model, pl, &seq.phases, steps, rad);
    let batches = if opts.quick { 1 } else { 5 };
    let fast_s = time_per_call(batches, 1, || {
        run_fast(&plane).expect("valid inputs");
    });
    // The f64 loop on the central 2 × 2 mm (11 × 11 points, the peak's
    // neighbourhood), scaled per point: it is linear in the points.
    let small = ObservationPlane {
        width_mm: 2.0,
        height_mm: 2.0,
        ..plane
    };
    let n_small = small.nu() * small.nv();
    let mut reference = None;
    let ref_s = time_per_call(if opts.quick { 1 } else { 3 }, 1, || {
        reference = Some(run_ref(&small).expect("valid inputs"));
    });
    let reference = reference.expect("ran at least once");
    let fast_small = run_fast(&small)?;
    let points = plane.nu() * plane.nv();
    let reference_s_per_point = ref_s / n_small as f64;
    let reference_full_s = reference_s_per_point * points as f64;
    let f = FieldFigures {
        case: format!(
            "LM-M A = 3 mm, 4 foci, built-in 2x2 AUTD3, {} × {} grid at 0.2 mm",
            plane.nu(),
            plane.nv()
        ),
        points,
        transducers: model.transducers(),
        steps,
        isa: fast_path_isa().to_string(),
        fast_s,
        reference_s_per_point,
        reference_full_s,
        speedup: reference_full_s / fast_s,
        compared_points: n_small,
        rel_err_peak_mean: rel_at_peak(&fast_small.mean_pressure_pa, &reference.mean_pressure_pa),
        rel_err_peak_lm_power: rel_at_peak(&fast_small.lm_power_pa2, &reference.lm_power_pa2),
        rel_err_peak_step0: rel_at_peak(&fast_small.pressure_pa, &reference.pressure_pa),
        max_err_over_peak: max_over_peak(&fast_small, &reference),
    };
    let text = format!(
        "field ({}; {} points × {} transducers × {} steps)\n  \
         fast path ({}, 2 threads): {:.3} s for all maps; f64 loop: {:.3} s estimated \
         ({:.1} µs/point, one thread) → {:.1}x\n  \
         fast vs f64 on the central {} points: rel. error at the peak {:.1e} (mean), \
         {:.1e} (LM power), {:.1e} (step 0); max error / peak {:.1e}\n",
        f.case,
        f.points,
        f.transducers,
        f.steps,
        f.isa,
        f.fast_s,
        f.reference_full_s,
        f.reference_s_per_point * 1e6,
        f.speedup,
        f.compared_points,
        f.rel_err_peak_mean,
        f.rel_err_peak_lm_power,
        f.rel_err_peak_step0,
        f.max_err_over_peak,
    );
    Section::new("field", &f, text)
}
