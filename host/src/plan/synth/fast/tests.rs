//! Accuracy of the fast path against the f64 reference: seeded random
//! foci, weights, named hard cases, both kernel builds.

use super::kernels::{atan2_turns, cos_sin_turns};
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
    let plan = plan();
    let f = [5.0, -7.0, 180.0];
    let (mut a, mut b) = (vec![0u8; plan.len()], vec![0u8; plan.len()]);
    plan.focus(f, &mut a);
    plan.foci(&[f, f, f, f], None, &mut plan.scratch(), &mut b);
    let diff = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    // Both are within 0.51 LSB of the same exact phase; they may only
    // differ where that phase sits on a rounding tie.
    assert!(diff < 5, "{diff} transducers differ");
    assert!(max_err(&plan, &[f, f, f, f], None) <= 0.51);
}

#[test]
fn cancelling_foci_are_finite_and_exact() {
    let plan = plan();
    let f = [0.0, 0.0, 150.0];
    let w = [Weight::ONE, Weight::real(-1.0)];
    let mut out = vec![0u8; plan.len()];
    plan.foci(&[f, f], Some(&w), &mut plan.scratch(), &mut out);
    for (&q, &p) in out.iter().zip(plan.positions()) {
        let want = crate::plan::synth::quantise_turns(reference::phase_turns(
            p,
            &[f, f],
            Some(&w),
            plan.kappa,
        ));
        assert_eq!(q, want);
    }
    // Half a wavelength apart along the axis: many near-zero sums.
    let e = max_err(&plan, &[[0.0, 0.0, 150.0], [0.0, 0.0, 154.25]], None);
    assert!(e <= 0.51, "{e}");
}

#[test]
fn focus_on_a_transducer_and_behind_the_array() {
    let plan = plan();
    let on = plan.positions()[123];
    assert!(max_err(&plan, &[on], None) <= 0.51);
    assert!(max_err(&plan, &[on, [0.0, 0.0, 200.0]], None) <= 0.51);
    let mut out = vec![0u8; plan.len()];
    plan.focus(on, &mut out);
    assert_eq!(out[123], 0);
    assert!(max_err(&plan, &[[10.0, 20.0, -150.0]], None) <= 0.51);
    // Focus exactly at the centroid (r0 = 0, the near kernel).
    assert!(max_err(&plan, &[plan.centroid], None) <= 0.51);
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
    assert_eq!(plan.len(), 13);
    assert!(max_err(&plan, &[[0.0, 0.0, 100.0]], None) <= 0.51);
    assert!(max_err(&plan, &[[0.0, 0.0, 100.0], [3.0, 0.0, 100.0]], None) <= 0.51);
}

#[test]
fn kernels_are_accurate_alone() {
    kernels_accurate::<false>();
    kernels_accurate::<true>();
}

fn kernels_accurate<const F: bool>() {
    let mut worst: f32 = 0.0;
    for i in -2000..=2000 {
        let t = i as f32 / 997.0;
        let (c, s) = cos_sin_turns::<F>(t);
        let a = 2.0 * std::f64::consts::PI * f64::from(t);
        worst = worst.max((f64::from(c) - a.cos()).abs() as f32);
        worst = worst.max((f64::from(s) - a.sin()).abs() as f32);
        let (y, x) = (s * 0.7, c * 0.7);
        let at = f64::from(atan2_turns::<F>(y, x));
        let want = f64::from(y).atan2(f64::from(x)) / (2.0 * std::f64::consts::PI);
        let d = (at - want).rem_euclid(1.0);
        worst = worst.max(d.min(1.0 - d) as f32);
    }
    assert!(worst < 1e-5, "{worst}");
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
