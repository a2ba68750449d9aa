//! Phase synthesis speed over the built-in 2 × 2 AUTD3 array (996
//! transducers): one frame with 1 and 4 foci, fast path (the build this
//! CPU runs, and the portable build) vs f64 reference,
//! and a whole LM-M sequence (A = 3 mm, N = 82, 4 foci: plan, synthesise,
//! quantise, Delta-encode). With `--features autd3-compare`, the `autd3`
//! crate's `Focus` gain on the same geometry and focus runs in the same
//! group.
//!
//! Run: `cargo bench -p lmhost --bench synth [--features autd3-compare]`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use lm_proto::codec::Encoding;
use lmhost::plan::scene::Scene;
use lmhost::plan::sequence::{Sequence, SynthWorkspace, Synthesis};
use lmhost::plan::synth::fast::SynthPlan;
use lmhost::plan::synth::{quantise_turns, reference};
use lmhost::plan::trajectory::{LmParams, Trajectory};

fn lm(foci: usize) -> (Scene, Trajectory) {
    let scene = Scene::default();
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.foci = foci;
    let t = Trajectory::plan(&p, &scene).expect("paper parameters plan");
    (scene, t)
}

fn frames(c: &mut Criterion) {
    let scene = Scene::default();
    let plan = SynthPlan::new(&scene.transducers(), scene.wavenumber_rad_per_mm());
    let kappa = plan.kappa_turns_per_mm();
    let mut out = vec![0u8; plan.len()];
    let mut scratch = plan.scratch();
    // The baseline build (SSE2 on x86-64, no FMA), for CPUs without AVX2.
    let portable = plan.clone().portable();
    for foci in [1, 4] {
        let (_, t) = lm(foci);
        let mut g = c.benchmark_group(format!("frame_{foci}_foci_996"));
        let mut j = 0;
        g.bench_function("fast_f32", |b| {
            b.iter(|| {
                j = (j + 1) % t.steps;
                plan.foci(black_box(t.drive_step(j)), None, &mut scratch, &mut out);
            })
        });
        g.bench_function("fast_f32_portable", |b| {
            b.iter(|| {
                j = (j + 1) % t.steps;
                portable.foci(black_box(t.drive_step(j)), None, &mut scratch, &mut out);
            })
        });
        g.bench_function("reference_f64", |b| {
            b.iter(|| {
                j = (j + 1) % t.steps;
                reference::frame_with(
                    plan.positions(),
                    black_box(t.drive_step(j)),
                    None,
                    kappa,
                    &mut out,
                    quantise_turns,
                );
            })
        });
        #[cfg(feature = "autd3-compare")]
        if foci == 1 {
            autd3_cmp::bench(&mut g, &t);
        }
        g.finish();
    }
}

fn sequence(c: &mut Criterion) {
    let scene = Scene::default();
    let plan = SynthPlan::new(&scene.transducers(), scene.wavenumber_rad_per_mm());
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.foci = 4;
    let mut g = c.benchmark_group("sequence_lm_m_a3_n82_4foci");
    let mut enc = vec![0u8; 82 * 996];
    let mut ws = SynthWorkspace::new(&plan);
    g.bench_function("plan_synth_quantise_delta", |b| {
        b.iter(|| {
            let t = Trajectory::plan(black_box(&p), &scene).expect("plans");
            let s = Sequence::synthesize_reusing(&scene, &plan, &mut ws, &t, &Synthesis::Linear)
                .expect("synth");
            black_box(s.encode_into(Encoding::Delta, &mut enc))
        })
    });
    let t = Trajectory::plan(&p, &scene).expect("plans");
    g.bench_function("synth_quantise_only", |b| {
        b.iter(|| {
            Sequence::synthesize_reusing(&scene, &plan, &mut ws, black_box(&t), &Synthesis::Linear)
                .expect("synth")
        })
    });
    let s = Sequence::synthesize_with(&scene, &plan, &t, &Synthesis::Linear).expect("synth");
    g.bench_function("delta_encode_only", |b| {
        b.iter(|| black_box(s.encode_into(Encoding::Delta, &mut enc)))
    });
    g.finish();
}

#[cfg(feature = "autd3-compare")]
mod autd3_cmp {
    use autd3::core::environment::Environment;
    use autd3::core::gain::{Gain, GainCalculator, GainCalculatorGenerator, TransducerMask};
    use autd3::prelude::*;
    use criterion::BenchmarkGroup;
    use criterion::measurement::WallTime;
    use lmhost::plan::array::autd3_local_center_mm;
    use lmhost::plan::trajectory::Trajectory;
    use std::hint::black_box;

    /// The same four devices as `Scene::default()`: AUTD3 places a device by
    /// its transducer 0, our scene by its grid centre.
    pub fn geometry() -> Geometry {
        let c = autd3_local_center_mm();
        let (hx, hy) = (96.0, 75.7);
        Geometry::new(
            [[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]]
                .iter()
                .map(|&[x, y]| {
                    AUTD3::new(
                        Point3::new((x - c[0]) as f32, (y - c[1]) as f32, 0.0),
                        UnitQuaternion::identity(),
                    )
                    .into()
                })
                .collect(),
        )
    }

    pub fn bench(g: &mut BenchmarkGroup<'_, WallTime>, t: &Trajectory) {
        let geo = geometry();
        let env = Environment::new();
        let mut out = vec![0u8; 996];
        let mut j = 0;
        g.bench_function("autd3_focus", |b| {
            b.iter(|| {
                j = (j + 1) % t.steps;
                let f = t.drive_step(j)[0];
                let focus = Focus::new(
                    Point3::new(f[0] as f32, f[1] as f32, f[2] as f32),
                    FocusOption::default(),
                );
                let mut generator = focus
                    .init(&geo, &env, &TransducerMask::AllEnabled)
                    .expect("focus inits");
                let mut i = 0;
                for dev in geo.iter() {
                    let calc = generator.generate(dev);
                    for tr in dev.iter() {
                        out[i] = calc.calc(tr).phase.0;
                        i += 1;
                    }
                }
                black_box(&out);
            })
        });
    }
}

criterion_group!(benches, frames, sequence);
criterion_main!(benches);
