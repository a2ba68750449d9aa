//! The `planner` section of `lmhost bench`: synthesis per frame (fast path,
//! portable build, f64 reference), whole sequences, and the solvers.

use lm_proto::codec::Encoding;
use serde::Serialize;

use super::{Options, Section, time_per_call};
use crate::geom::{self, Vec3};
use crate::plan::scene::Scene;
use crate::plan::sequence::{Sequence, SynthWorkspace, Synthesis};
use crate::plan::synth::fast::SynthPlan;
use crate::plan::synth::{Weight, error_lsb, quantise_turns, reference, solver};
use crate::plan::trajectory::{LmParams, Trajectory};

/// Frame timing and accuracy of one synthesis case.
#[derive(Debug, Clone, Serialize)]
pub struct FrameFigures {
    /// Foci per frame.
    pub foci: usize,
    /// Transducers.
    pub transducers: usize,
    /// Kernel build the fast path ran (`Avx2Fma` or `Portable`).
    pub isa: crate::plan::synth::fast::Isa,
    /// Fast path, µs per frame (median).
    pub fast_us: f64,
    /// Fast path forced to the portable build, µs per frame (median).
    pub portable_us: f64,
    /// f64 reference, µs per frame (median).
    pub reference_us: f64,
    /// Max |error| of the fast u8 against the exact phase (LSB).
    pub max_err_lsb: f64,
    /// Mean |error| (LSB).
    pub mean_err_lsb: f64,
    /// Frames checked for the error figures.
    pub frames_checked: usize,
}

/// Whole-sequence figures.
#[derive(Debug, Clone, Serialize)]
pub struct SequenceFigures {
    /// What was planned.
    pub case: String,
    /// Steps.
    pub steps: usize,
    /// Plan + synthesise + quantise + Delta-encode, µs (median).
    pub total_us: f64,
    /// Synthesise + quantise only, µs (median).
    pub synth_us: f64,
    /// Delta-encode only (`lm_proto::codec::encode`), µs (median).
    pub encode_us: f64,
    /// Raw bytes.
    pub raw_bytes: usize,
    /// Delta bytes.
    pub delta_bytes: usize,
    /// Delta / raw.
    pub delta_ratio: f64,
}

/// Pressure per focus for one solver.
#[derive(Debug, Clone, Serialize)]
pub struct SolverFigures {
    /// Which foci.
    pub case: String,
    /// Solver name.
    pub solver: String,
    /// Pressure at each focus (a.u., point sources, 1/r, directivity).
    pub pressures: Vec<f64>,
    /// min / max over the foci.
    pub uniformity: f64,
    /// Mean pressure.
    pub mean: f64,
}

/// The planner section.
#[derive(Debug, Clone, Serialize)]
pub struct PlannerFigures {
    /// Per-frame figures, 1 and 4 foci.
    pub frames: Vec<FrameFigures>,
    /// Whole sequences.
    pub sequences: Vec<SequenceFigures>,
    /// Linear vs GS-PAT vs weighted.
    pub solvers: Vec<SolverFigures>,
}

fn frame_case(scene: &Scene, plan: &SynthPlan, traj: &Trajectory, opts: &Options) -> FrameFigures {
    let t = plan.len();
    let kappa = plan.kappa_turns_per_mm();
    let mut out = vec![0u8; t];
    let mut exact = vec![0.0f64; t];
    let mut scratch = plan.scratch();
    let (mut max, mut sum, mut cnt) = (0.0f64, 0.0, 0usize);
    for j in 0..traj.steps {
        let foci = traj.drive_step(j);
        plan.foci(foci, None, &mut scratch, &mut out);
        reference::frame_with(plan.positions(), foci, None, kappa, &mut exact, |t| t);
        for (&q, &e) in out.iter().zip(&exact) {
            let d = error_lsb(q, e);
            max = max.max(d);
            sum += d;
            cnt += 1;
        }
    }
    let (b, r) = if opts.quick { (3, 20) } else { (15, 400) };
    let mut j = 0;
    // The chosen kernels, then the portable ones, on the same steps.
    let mut time_plan = |p: &SynthPlan| {
        time_per_call(b, r, || {
            p.foci(
                traj.drive_step(j % traj.steps),
                None,
                &mut scratch,
                &mut out,
            );
            j += 1;
        })
    };
    let fast = time_plan(plan);
    let portable = time_plan(&plan.clone().portable());
    let mut q = vec![0u8; t];
    let reference = time_per_call(b, r / 10, || {
        reference::frame_with(
            plan.positions(),
            traj.drive_step(j % traj.steps),
            None,
            kappa,
            &mut q,
            quantise_turns,
        );
        j += 1;
    });
    let _ = scene;
    FrameFigures {
        foci: traj.foci,
        transducers: t,
        isa: plan.isa(),
        fast_us: fast * 1e6,
        portable_us: portable * 1e6,
        reference_us: reference * 1e6,
        max_err_lsb: max,
        mean_err_lsb: sum / cnt.max(1) as f64,
        frames_checked: traj.steps,
    }
}

fn solver_cases(scene: &Scene, case: &str, foci: &[Vec3]) -> Vec<SolverFigures> {
    let t = scene.transducers();
    let k = scene.wavenumber_rad_per_mm();
    let m = foci.len();
    let mut out = Vec::new();
    let mut add = |name: &str, turns: Vec<f64>| {
        let p = solver::focus_pressures(&t, &turns, foci, k, scene.directivity);
        let max = p.iter().cloned().fold(0.0, f64::max);
        let min = p.iter().cloned().fold(f64::INFINITY, f64::min);
        out.push(SolverFigures {
            case: case.to_string(),
            solver: name.to_string(),
            uniformity: min / max,
            mean: p.iter().sum::<f64>() / m as f64,
            pressures: p,
        });
    };
    add(
        "linear (paper)",
        solver::weighted_turns(&t, foci, &vec![Weight::ONE; m], k),
    );
    // Weighted: each focus weighted by its distance (compensates 1/r).
    let c = geom::scale(
        t.iter().fold([0.0; 3], |a, tr| geom::add(a, tr.pos_mm)),
        1.0 / t.len() as f64,
    );
    let w: Vec<Weight> = foci
        .iter()
        .map(|f| Weight::real(geom::norm(geom::sub(*f, c))))
        .collect();
    add("weighted (w = r)", solver::weighted_turns(&t, foci, &w, k));
    add(
        "gs-pat (20 it)",
        solver::gspat_turns(&t, foci, k, scene.directivity, 20),
    );
    out
}

/// Measures the planner: frames, sequences, solvers.
pub fn section(opts: &Options) -> anyhow::Result<Section> {
    let scene = Scene::default();
    let plan = SynthPlan::new(&scene.transducers(), scene.wavenumber_rad_per_mm());
    let mut frames = Vec::new();
    let mut sequences = Vec::new();
    for foci in [1, 4] {
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.foci = foci;
        let traj = Trajectory::plan(&p, &scene)?;
        frames.push(frame_case(&scene, &plan, &traj, opts));
        let (b, r) = if opts.quick { (3, 2) } else { (11, 20) };
        let mut last = None;
        let mut ws = SynthWorkspace::new(&plan);
        let total = time_per_call(b, r, || {
            let traj = Trajectory::plan(&p, &scene).expect("planned above");
            let s = Sequence::synthesize_reusing(&scene, &plan, &mut ws, &traj, &Synthesis::Linear)
                .expect("planned above");
            let enc = s
                .encode(Encoding::Delta)
                .expect("synthesised: steps × transducers");
            last = Some((s, enc.len()));
        });
        let (s, delta) = last.expect("ran at least once");
        let synth = time_per_call(b, r, || {
            let _ = Sequence::synthesize_reusing(&scene, &plan, &mut ws, &traj, &Synthesis::Linear);
        });
        let mut enc = vec![0u8; delta];
        let encode = time_per_call(b, r, || {
            let _ = s.encode_into(Encoding::Delta, &mut enc);
        });
        sequences.push(SequenceFigures {
            case: format!(
                "{} A = 3 mm, d_LM = 0.23 mm, {foci} foci",
                if foci == 1 { "LM-S" } else { "LM-M" }
            ),
            steps: traj.steps,
            total_us: total * 1e6,
            synth_us: synth * 1e6,
            encode_us: encode * 1e6,
            raw_bytes: s.phases.len(),
            delta_bytes: delta,
            delta_ratio: delta as f64 / s.phases.len() as f64,
        });
    }
    let mut p = LmParams::paper([0.0, 0.0, 220.0]);
    p.cycle.radius_mm = 6.0;
    p.cycle.foci = 4;
    let lmm = Trajectory::plan(&p, &scene)?;
    let mut solvers = solver_cases(
        &scene,
        "LM-M A = 6 mm at (0,0,220), step 0",
        lmm.drive_step(0),
    );
    solvers.extend(solver_cases(
        &scene,
        "4 spread foci, z = 120..300 mm",
        &[
            [-40.0, -40.0, 120.0],
            [40.0, -40.0, 160.0],
            [-40.0, 40.0, 220.0],
            [60.0, 60.0, 300.0],
        ],
    ));
    let mut text = String::from("planner (built-in 2x2 AUTD3, 996 transducers, one thread)\n");
    for f in &frames {
        let FrameFigures {
            foci,
            fast_us,
            isa,
            portable_us,
            reference_us,
            max_err_lsb,
            mean_err_lsb,
            frames_checked,
            ..
        } = f;
        let speedup = reference_us / fast_us;
        text += &format!(
            "  frame, {foci} foci: fast {fast_us:.2} µs ({isa:?}; portable {portable_us:.2} µs), f64 reference {reference_us:.2} µs ({speedup:.1}x); error max {max_err_lsb:.3} LSB, mean {mean_err_lsb:.3} LSB over {frames_checked} frames\n"
        );
    }
    for s in &sequences {
        let SequenceFigures {
            case,
            steps,
            total_us,
            synth_us,
            encode_us,
            raw_bytes,
            delta_bytes,
            delta_ratio,
        } = s;
        let percent = 100.0 * delta_ratio;
        text += &format!(
            "  sequence {case} (N = {steps}): plan+synth+quantise+delta {total_us:.1} µs (synth {synth_us:.1} µs, delta encode {encode_us:.1} µs); raw {raw_bytes} B, delta {delta_bytes} B ({percent:.1} %)\n"
        );
    }
    for s in &solvers {
        let p: Vec<String> = s.pressures.iter().map(|x| format!("{x:.2}")).collect();
        text += &format!(
            "  {} / {}: pressures [{}] a.u., min/max {:.3}, mean {:.2}\n",
            s.case,
            s.solver,
            p.join(", "),
            s.uniformity,
            s.mean
        );
    }
    Section::new(
        "planner",
        &PlannerFigures {
            frames,
            sequences,
            solvers,
        },
        text,
    )
}
