//! Accuracy of the fast path against the f64 reference: seeded random
//! foci, weights, named hard cases, both kernel builds.

use super::kernels::{atan2_lsb, phasor};
use super::lanes::{Arr, LANES, Lanes};
use super::*;
use crate::plan::scene::Scene;
use crate::plan::synth::{error_lsb, reference};
use crate::rng::SplitMix64;

fn plan() -> SynthPlan {
    let s = Scene::default();
    SynthPlan::new(&s.transducers(), s.wavenumber_rad_per_mm())
}

/// The detected build and the portable one.
fn plans() -> [SynthPlan; 2] {
    [plan(), plan().portable()]
}

/// `m` seeded points, `x, y` uniform in `[−xy, xy)`, `z` in `[z.0, z.1)`.
fn random_points(rng: &mut SplitMix64, m: usize, xy: f64, z: (f64, f64)) -> Vec<Vec3> {
    (0..m)
        .map(|_| {
            [
                rng.uniform(-xy, xy),
                rng.uniform(-xy, xy),
                rng.uniform(z.0, z.1),
            ]
        })
        .collect()
}

/// Max error in LSB of the fast path against the exact f64 phase.
fn max_err(plan: &SynthPlan, foci: &[Vec3], w: Option<&[Weight]>) -> f64 {
    let mut out = vec![0u8; plan.len()];
    let mut s = plan.scratch();
    plan.foci(foci, w, &mut s, &mut out);
    out.iter()
        .zip(plan.positions())
        .map(|(&q, &p)| error_lsb(q, reference::phase_turns(p, foci, w, plan.kappa)))
        .fold(0.0, f64::max)
}

#[test]
fn seeded_random_foci_are_within_0_51_lsb() {
    for plan in plans() {
        seeded_random(&plan);
    }
}

fn seeded_random(plan: &SynthPlan) {
    random_foci_within_0_51_lsb(plan, 0x5eed, 300, 300.0, (-50.0, 600.0));
}

/// `cases` seeded random focus sets of 1-4 foci (see [`random_points`])
/// are each within 0.51 LSB of the exact phase.
fn random_foci_within_0_51_lsb(plan: &SynthPlan, seed: u64, cases: usize, xy: f64, z: (f64, f64)) {
    let mut rng = SplitMix64::new(seed);
    for case in 0..cases {
        let m = 1 + case % 4;
        let foci: Vec<Vec3> = random_points(&mut rng, m, xy, z);
        let e = max_err(plan, &foci, None);
        assert!(
            e <= 0.51,
            "{:?} case {case}: {e} LSB for {foci:?}",
            plan.isa()
        );
    }
}

/// 10^5 seeded random focus sets (1-4 foci, ±1 m, both builds): run by
/// `cargo test --release -p lmhost --lib -- --ignored long_random`.
#[test]
#[ignore = "long: run in release by cargo xtask ci"]
fn long_random_foci_are_within_0_51_lsb() {
    let cases = (50_000.0 * long_scale()).round() as usize;
    for plan in plans() {
        random_foci_within_0_51_lsb(&plan, 0x10_0000, cases, 1000.0, (-1000.0, 1000.0));
    }
}

/// The long run's share of its full size: `LM_LONG_SCALE` in (0, 1] (the
/// CI's everyday run), 1 when unset (`cargo xtask ci --full`).
fn long_scale() -> f64 {
    let s = std::env::var("LM_LONG_SCALE")
        .ok()
        .and_then(|s| s.parse().ok());
    s.filter(|s: &f64| *s > 0.0 && *s <= 1.0).unwrap_or(1.0)
}

#[test]
fn weighted_random_foci_are_within_0_51_lsb() {
    for plan in plans() {
        weighted_random(&plan);
    }
}

fn weighted_random(plan: &SynthPlan) {
    let mut rng = SplitMix64::new(42);
    for case in 0..50 {
        let foci: Vec<Vec3> = random_points(&mut rng, 3, 50.0, (100.0, 300.0));
        let w: Vec<Weight> = (0..3)
            .map(|_| Weight {
                re: rng.uniform(-1.0, 1.0),
                im: rng.uniform(-1.0, 1.0),
            })
            .collect();
        let e = max_err(plan, &foci, Some(&w));
        assert!(e <= 0.51, "case {case}: {e} LSB");
    }
}

#[test]
fn coincident_foci_match_a_single_focus() {
    for plan in plans() {
        let f = [5.0, -7.0, 180.0];
        let (mut a, mut b) = (vec![0u8; plan.len()], vec![0u8; plan.len()]);
        plan.focus(f, &mut a);
        plan.foci(&[f, f, f, f], None, &mut plan.scratch(), &mut b);
        let diff = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        // Both are within 0.51 LSB of the same exact phase; they may only
        // differ where that phase sits on a rounding tie.
        assert!(diff < 5, "{:?}: {diff} transducers differ", plan.isa());
        assert!(max_err(&plan, &[f, f, f, f], None) <= 0.51);
        // Four foci at one far point (the far kernel in the sums).
        let far = [2.0e5, -1.0e5, 3.0e5];
        assert!(max_err(&plan, &[far, far, far, far], None) <= 0.51);
    }
}

#[test]
fn cancelling_foci_are_finite_and_exact() {
    for plan in plans() {
        let f = [0.0, 0.0, 150.0];
        let w = [Weight::ONE, Weight::real(-1.0)];
        let mut out = vec![0u8; plan.len()];
        plan.foci(&[f, f], Some(&w), &mut plan.scratch(), &mut out);
        assert_eq!(out, exact(&plan, &[f, f], Some(&w)), "{:?}", plan.isa());
        // Half a wavelength apart along the axis: many near-zero sums.
        let e = max_err(&plan, &[[0.0, 0.0, 150.0], [0.0, 0.0, 154.25]], None);
        assert!(e <= 0.51, "{:?}: {e}", plan.isa());
    }
}

/// The reference frame, quantised: what the f64 fix-up writes.
fn exact(plan: &SynthPlan, foci: &[Vec3], w: Option<&[Weight]>) -> Vec<u8> {
    plan.positions()
        .iter()
        .map(|&p| {
            crate::plan::synth::quantise_turns(reference::phase_turns(p, foci, w, plan.kappa))
        })
        .collect()
}

#[test]
fn vanishing_weights_are_redone_in_f64_everywhere() {
    // Weights below f32's normal range: the f32 sums lose their
    // precision (or are exactly zero, their angle NaN) and `|S|²` and its
    // threshold both underflow to zero. The threshold must still flag
    // every transducer, so the frame is the f64 reference's.
    for plan in plans() {
        let foci = [[0.0, 0.0, 200.0], [10.0, 0.0, 200.0], [0.0, 0.0, 1.0e6]];
        for w in [1.0e-41, 1.0e-44, 0.0] {
            let w = [Weight::real(w), Weight { re: 0.0, im: w }, Weight::real(w)];
            let mut out = vec![0x5a; plan.len()];
            plan.foci(&foci, Some(&w), &mut plan.scratch(), &mut out);
            let want = exact(&plan, &foci, Some(&w));
            let wrong = out.iter().zip(&want).filter(|(a, b)| a != b).count();
            assert_eq!(
                wrong,
                0,
                "{:?} {w:?}: transducers off the reference",
                plan.isa()
            );
        }
    }
}

#[test]
fn focus_on_a_transducer_and_behind_the_array() {
    for plan in plans() {
        let on = plan.positions()[123];
        assert!(max_err(&plan, &[on], None) <= 0.51);
        assert!(max_err(&plan, &[on, [0.0, 0.0, 200.0]], None) <= 0.51);
        // Four foci on the same transducer: a zero distance in every pass.
        assert!(max_err(&plan, &[on, on, on, on], None) <= 0.51);
        let mut out = vec![0u8; plan.len()];
        plan.focus(on, &mut out);
        assert_eq!(out[123], 0);
        assert!(max_err(&plan, &[[10.0, 20.0, -150.0]], None) <= 0.51);
        // Focus exactly at the centroid (r0 = 0, the near kernel).
        assert!(max_err(&plan, &[plan.centroid], None) <= 0.51);
        assert!(max_err(&plan, &[plan.centroid, on], None) <= 0.51);
    }
}

#[test]
fn very_large_coordinates_keep_precision() {
    for plan in plans() {
        large_coordinates(&plan);
    }
}

fn large_coordinates(plan: &SynthPlan) {
    for f in [
        [1.0e6, -2.0e6, 3.0e6],
        [0.0, 0.0, 1.0e8],
        [-7.3e7, 1.1e5, -4.0e7],
        [0.0, 0.0, 700.0],
    ] {
        let e = max_err(plan, &[f], None);
        assert!(e <= 0.51, "{f:?}: {e}");
        let e = max_err(plan, &[f, [f[0] + 3.0, f[1], f[2]]], None);
        assert!(e <= 0.51, "{f:?} pair: {e}");
    }
}

#[test]
fn table_path_matches_the_reference() {
    for plan in plans() {
        let mut rng = SplitMix64::new(7);
        let pts: Vec<Vec3> = random_points(&mut rng, 12, 20.0, (150.0, 250.0));
        let table = plan.phasor_table(&pts);
        assert_eq!(table.len(), 12);
        let mut out = vec![0u8; plan.len()];
        let mut s = plan.scratch();
        for idx in [&[0usize, 3, 6, 9][..], &[1, 1], &[11, 0, 5]] {
            let foci: Vec<Vec3> = idx.iter().map(|&k| pts[k]).collect();
            plan.foci_from_table(&table, idx, None, &mut s, &mut out);
            for (&q, &p) in out.iter().zip(plan.positions()) {
                let e = error_lsb(q, reference::phase_turns(p, &foci, None, plan.kappa));
                assert!(e <= 0.51, "{:?} {idx:?}: {e}", plan.isa());
            }
            let w = vec![Weight { re: 0.3, im: -0.8 }; idx.len()];
            plan.foci_from_table(&table, idx, Some(&w), &mut s, &mut out);
            for (&q, &p) in out.iter().zip(plan.positions()) {
                let e = error_lsb(q, reference::phase_turns(p, &foci, Some(&w), plan.kappa));
                assert!(e <= 0.51, "{:?} weighted {idx:?}: {e}", plan.isa());
            }
        }
    }
}

#[test]
fn odd_transducer_counts_use_the_tail_path() {
    let s = Scene::default();
    let t = &s.transducers()[..13];
    let plan = SynthPlan::new(t, s.wavenumber_rad_per_mm());
    for plan in [plan.clone(), plan.portable()] {
        assert_eq!(plan.len(), 13);
        assert!(max_err(&plan, &[[0.0, 0.0, 100.0]], None) <= 0.51);
        assert!(max_err(&plan, &[[0.0, 0.0, 100.0], [3.0, 0.0, 100.0]], None) <= 0.51);
        // A far focus through the tail block too.
        assert!(max_err(&plan, &[[0.0, 0.0, 5.0e4]], None) <= 0.51);
    }
}

#[test]
fn kernels_are_accurate_alone() {
    let mut runs = vec![("plain arrays", lanes_accuracy::<Arr>())];
    #[cfg(target_arch = "x86_64")]
    runs.push(("SSE2", lanes_accuracy::<super::sse2::Sse>()));
    #[cfg(target_arch = "x86_64")]
    runs.extend(super::avx2::lanes_accuracy().map(|e| ("AVX2 + FMA", e)));
    for (lanes, (phasor_err, angle_err)) in runs {
        eprintln!("{lanes}: phasor error {phasor_err:e}, angle error {angle_err:e} LSB");
        assert!(phasor_err < 6e-7, "{lanes}: {phasor_err}");
        assert!(angle_err < 2e-5, "{lanes}: {angle_err} LSB");
    }
}

/// Worst absolute error of [`phasor`] over `u` in `[−½, ½]` and of
/// [`atan2_lsb`] (LSB) on those phasors scaled by 0.7 and 3.
#[inline(always)]
pub(super) fn lanes_accuracy<V: Lanes>() -> (f64, f64) {
    const STEPS: i32 = 1 << 16;
    let (mut worst_phasor, mut worst_angle) = (0.0f64, 0.0f64);
    for block in (-STEPS / 2..=STEPS / 2).step_by(LANES) {
        let ua: [f32; LANES] = std::array::from_fn(|l| (block + l as i32) as f32 / STEPS as f32);
        let (c, s) = phasor(V::load(&ua));
        for scale in [0.7, 3.0] {
            let (x, y) = (c * V::splat(scale), s * V::splat(scale));
            let a = atan2_lsb(y, x).to_array();
            let (c, s, x, y) = (c.to_array(), s.to_array(), x.to_array(), y.to_array());
            for l in 0..LANES {
                let t = 2.0 * std::f64::consts::PI * f64::from(ua[l]);
                worst_phasor = worst_phasor
                    .max((f64::from(c[l]) - t.cos()).abs())
                    .max((f64::from(s[l]) + t.sin()).abs());
                let want = f64::from(y[l]).atan2(f64::from(x[l])) * 128.0 / std::f64::consts::PI;
                let d = (f64::from(a[l]) - want).rem_euclid(256.0);
                worst_angle = worst_angle.max(d.min(256.0 - d));
            }
        }
    }
    (worst_phasor, worst_angle)
}

#[test]
fn kernel_set_is_chosen_once_at_plan_time() {
    assert_eq!(plan().isa(), Isa::detect());
    let p = plan().portable();
    assert_eq!(p.isa(), Isa::Portable);
    // A clone keeps the chosen set.
    assert_eq!(p.clone().isa(), Isa::Portable);
}

#[test]
fn cancelling_table_foci_take_the_f64_fix_up() {
    for plan in plans() {
        let f = [4.0, -3.0, 170.0];
        let table = plan.phasor_table(&[[0.0, 0.0, 150.0], f]);
        let w = [Weight::ONE, Weight::real(-1.0)];
        let mut out = vec![0u8; plan.len()];
        plan.foci_from_table(&table, &[1, 1], Some(&w), &mut plan.scratch(), &mut out);
        for (&q, &p) in out.iter().zip(plan.positions()) {
            let want = crate::plan::synth::quantise_turns(reference::phase_turns(
                p,
                &[f, f],
                Some(&w),
                plan.kappa,
            ));
            assert_eq!(q, want, "{:?}", plan.isa());
        }
    }
}
