//! Physics tests of the field model and checks of the fast path against
//! the f64 reference.

use std::f64::consts::PI;

use super::*;
use crate::geom::{axpy, dot, normalized, sub};
use crate::plan::array::{Transducer, autd3_local_center_mm, autd3_local_positions_mm};
use crate::rng::SplitMix64;

const Z: [f64; 3] = [0.0, 0.0, 1.0];
const X: [f64; 3] = [1.0, 0.0, 0.0];
const Y: [f64; 3] = [0.0, 1.0, 0.0];

/// One AUTD3 centred on the origin, facing +z.
fn autd3() -> Vec<Transducer> {
    let c = autd3_local_center_mm();
    autd3_local_positions_mm()
        .map(|p| Transducer {
            pos_mm: [p[0] - c[0], p[1] - c[1], 0.0],
            normal: Z,
        })
        .collect()
}

/// A square `n × n` grid at 10 mm pitch centred on the origin: symmetric
/// under x ↔ −x, y ↔ −y and x ↔ y.
fn square(n: usize) -> Vec<Transducer> {
    let h = (n - 1) as f64 * 5.0;
    (0..n * n)
        .map(|i| Transducer {
            pos_mm: [(i % n) as f64 * 10.0 - h, (i / n) as f64 * 10.0 - h, 0.0],
            normal: Z,
        })
        .collect()
}

/// Exact focusing phases φ = −k r (rad).
fn focus_rad(tr: &[Transducer], k: f64, f: [f64; 3]) -> Vec<f64> {
    tr.iter()
        .map(|t| -k * dot(sub(f, t.pos_mm), sub(f, t.pos_mm)).sqrt())
        .collect()
}

fn quantise(rad: &[f64]) -> Vec<u8> {
    rad.iter()
        .map(|p| ((p / (2.0 * PI) * 256.0).round().rem_euclid(256.0)) as u8)
        .collect()
}

fn plane_around(c: [f64; 3], half: f64, step: f64) -> ObservationPlane {
    ObservationPlane::xy(c, 2.0 * half, 2.0 * half, step)
}

fn rel_err_at_peak(fast: &[f64], reference: &[f64]) -> f64 {
    let (i, p) = peak(reference).unwrap();
    let at_peak = (fast[i] - p).abs() / p;
    let worst = fast
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / p;
    at_peak.max(worst)
}

#[test]
fn single_focus_peaks_within_half_a_millimetre_of_its_target() {
    let tr = autd3();
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    for target in [[0.0, 0.0, 150.0], [12.0, -7.0, 180.0], [-20.0, 15.0, 120.0]] {
        let ph = quantise(&focus_rad(&tr, model.wavenumber_rad_per_mm(), target));
        let plane = plane_around(target, 5.0, 0.1);
        let maps = simulate(&model, &plane, &ph, 1, Radiation::default()).unwrap();
        let (i, _) = peak(&maps.pressure_pa).unwrap();
        let got = plane.point(i % maps.nu, i / maps.nu);
        let d = sub(got, target);
        assert!(
            dot(d, d).sqrt() <= 0.5,
            "focus {target:?} peaked at {got:?}"
        );
    }
}

#[test]
fn focus_pressure_is_in_autd3s_range() {
    // 249 T4010A1 in phase at 150 mm on axis: about 249 · 4386 / 150 Pa
    // less the off-axis directivity, i.e. a few kPa (AUTD3's docs quote
    // ~5 kPa-class foci for one board).
    let tr = autd3();
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let f = [0.0, 0.0, 150.0];
    let drive = drive_from_rad(&focus_rad(&tr, model.wavenumber_rad_per_mm(), f));
    let p = model.pressure(f, &drive).abs();
    let upper = 249.0 * T4010A1_P0_PA_MM / 150.0;
    assert!(p < upper && p > 0.8 * upper, "{p} Pa vs {upper} Pa");
}

#[test]
fn symmetric_array_and_focus_give_a_symmetric_map() {
    let tr = square(10);
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let f = [0.0, 0.0, 100.0];
    let ph = quantise(&focus_rad(&tr, model.wavenumber_rad_per_mm(), f));
    let plane = plane_around(f, 6.0, 0.3);
    let m = simulate(&model, &plane, &ph, 1, Radiation::default()).unwrap();
    let (n, p) = (m.nu, peak(&m.pressure_pa).unwrap().1);
    assert_eq!(m.nv, n);
    let at = |iu: usize, iv: usize| m.pressure_pa[iv * n + iu];
    for iv in 0..n {
        for iu in 0..n {
            for other in [at(n - 1 - iu, iv), at(iu, n - 1 - iv), at(iv, iu)] {
                assert!((at(iu, iv) - other).abs() <= 1e-5 * p, "({iu}, {iv})");
            }
        }
    }
    // And the map is not trivially flat.
    assert!(at(0, 0) < 0.2 * p);
}

#[test]
fn image_sources_equal_the_mirrored_scene() {
    let tr = autd3();
    // A tilted reflector below the array's focus region.
    let refl = Reflector {
        point_mm: [0.0, 0.0, 250.0],
        normal: [0.2, -0.3, -1.0],
    };
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), Some(refl)).unwrap();
    // The same scene built by hand: transducers plus their mirror images,
    // each image driven like its transducer.
    let n = normalized(refl.normal).unwrap();
    let mut both = tr.clone();
    for t in &tr {
        let h = dot(sub(t.pos_mm, refl.point_mm), n);
        let m = dot(t.normal, n);
        both.push(Transducer {
            pos_mm: axpy(-2.0 * h, n, t.pos_mm),
            normal: axpy(-2.0 * m, n, t.normal),
        });
    }
    let mirrored = FieldModel::new(&both, Directivity::T4010A1, Medium::default(), None).unwrap();
    let k = model.wavenumber_rad_per_mm();
    let ph = quantise(&focus_rad(&tr, k, [5.0, 5.0, 180.0]));
    let d1 = drive_from_u8(&ph);
    let d2: Vec<C64> = d1.iter().chain(&d1).copied().collect();
    for p in [[5.0, 5.0, 180.0], [-30.0, 10.0, 100.0], [0.0, -40.0, 240.0]] {
        let a = model.pressure(p, &d1);
        let b = mirrored.pressure(p, &d2);
        assert!(
            (a.re - b.re).abs() + (a.im - b.im).abs() <= 1e-9 * b.abs(),
            "{p:?}"
        );
    }
    // Behind the reflector the field is zero.
    assert_eq!(model.pressure([0.0, 0.0, 300.0], &d1), C64::default());
}

#[test]
fn radiation_pressure_scales_with_amplitude_squared() {
    let tr = autd3();
    let m1 = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let m2 = m1.clone().with_p0(2.0 * T4010A1_P0_PA_MM);
    let f = [0.0, 10.0, 160.0];
    let ph = quantise(&focus_rad(&tr, m1.wavenumber_rad_per_mm(), f));
    let plane = plane_around(f, 2.0, 0.5);
    let a = simulate_reference(&m1, &plane, &ph, 1, Radiation::default()).unwrap();
    let b = simulate_reference(&m2, &plane, &ph, 1, Radiation::default()).unwrap();
    for i in 0..a.pressure_pa.len() {
        assert!((b.amplitude_pa[i] - 2.0 * a.amplitude_pa[i]).abs() <= 1e-12 * b.amplitude_pa[i]);
        assert!((b.pressure_pa[i] - 4.0 * a.pressure_pa[i]).abs() <= 1e-12 * b.pressure_pa[i]);
    }
    // And the radiation pressure is α p² / (2 ρ c²) of the amplitude.
    let i = peak(&a.pressure_pa).unwrap().0;
    let want = 2.0 * a.amplitude_pa[i].powi(2) / (2.0 * 1.2 * 340.0 * 340.0);
    assert!((a.pressure_pa[i] - want).abs() <= 1e-12 * want);
}

#[test]
fn eight_bit_and_exact_phases_differ_by_less_than_a_tenth_of_a_percent() {
    let tr = autd3();
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    for f in [[0.0, 0.0, 150.0], [8.0, -4.0, 200.0], [-15.0, 20.0, 90.0]] {
        let exact = focus_rad(&tr, model.wavenumber_rad_per_mm(), f);
        let p_exact = model.pressure(f, &drive_from_rad(&exact)).norm_sqr();
        let p_u8 = model
            .pressure(f, &drive_from_u8(&quantise(&exact)))
            .norm_sqr();
        let rel = (p_u8 - p_exact).abs() / p_exact;
        assert!(rel < 1e-3, "{f:?}: {rel}");
    }
}

#[test]
fn fast_path_matches_the_f64_reference_on_seeded_inputs() {
    let mut rng = SplitMix64::new(0x5EED_F1E1D);
    let tr = autd3();
    for case in 0..4 {
        let medium = Medium {
            sound_speed_m_s: rng.uniform(330.0, 350.0),
            attenuation_np_per_m: if case % 2 == 0 { 0.0 } else { 1.15 },
            density_kg_m3: 1.2,
        };
        let refl = (case >= 2).then_some(Reflector {
            point_mm: [0.0, 0.0, 260.0],
            normal: [rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 1.0],
        });
        let dir = if case == 1 {
            Directivity::Omni
        } else {
            Directivity::T4010A1
        };
        let model = FieldModel::new(&tr, dir, medium, refl).unwrap();
        let k = model.wavenumber_rad_per_mm();
        let steps = 5 + case;
        let c = [
            rng.uniform(-10.0, 10.0),
            rng.uniform(-10.0, 10.0),
            rng.uniform(120.0, 200.0),
        ];
        // A small circular LM-like sequence plus seeded phase noise.
        let mut ph = Vec::new();
        for s in 0..steps {
            let a = 2.0 * PI * s as f64 / steps as f64;
            let f = [c[0] + 3.0 * a.cos(), c[1] + 3.0 * a.sin(), c[2]];
            let mut rad = focus_rad(&tr, k, f);
            for r in &mut rad {
                *r += rng.uniform(-0.3, 0.3);
            }
            ph.extend(quantise(&rad));
        }
        let plane = ObservationPlane {
            center_mm: c,
            u: X,
            v: [0.0, 0.6, 0.8],
            width_mm: 8.0,
            height_mm: 6.0,
            step_mm: 0.37,
        };
        let fast = simulate(&model, &plane, &ph, steps, Radiation::default()).unwrap();
        let refm = simulate_reference(&model, &plane, &ph, steps, Radiation::default()).unwrap();
        for (name, a, b) in [
            ("amplitude", &fast.amplitude_pa, &refm.amplitude_pa),
            ("pressure", &fast.pressure_pa, &refm.pressure_pa),
            ("mean", &fast.mean_pressure_pa, &refm.mean_pressure_pa),
            ("max", &fast.max_pressure_pa, &refm.max_pressure_pa),
            ("lm power", &fast.lm_power_pa2, &refm.lm_power_pa2),
        ] {
            let e = rel_err_at_peak(a, b);
            assert!(e < 1e-4, "case {case} {name}: {e}");
        }
    }
}

#[test]
fn fast_path_handles_odd_sizes_and_a_point_on_a_transducer() {
    // 3 transducers (not a multiple of any lane count), 3 steps (odd),
    // 5 × 3 points (odd), one grid point exactly on a transducer.
    let tr = vec![
        Transducer {
            pos_mm: [0.0, 0.0, 0.0],
            normal: Z,
        },
        Transducer {
            pos_mm: [10.0, 0.0, 0.0],
            normal: Z,
        },
        Transducer {
            pos_mm: [0.0, 10.0, 0.0],
            normal: [0.0, 0.6, 0.8],
        },
    ];
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let plane = ObservationPlane {
        center_mm: [0.0, 0.0, 0.0],
        u: X,
        v: Y,
        width_mm: 4.0,
        height_mm: 2.0,
        step_mm: 1.0,
    };
    let ph = [0u8, 64, 128, 10, 20, 30, 255, 0, 1];
    let fast = simulate(&model, &plane, &ph, 3, Radiation::default()).unwrap();
    let refm = simulate_reference(&model, &plane, &ph, 3, Radiation::default()).unwrap();
    assert_eq!((fast.nu, fast.nv), (5, 3));
    assert!(fast.mean_pressure_pa.iter().all(|v| v.is_finite()));
    assert!(rel_err_at_peak(&fast.mean_pressure_pa, &refm.mean_pressure_pa) < 1e-4);
    assert!(rel_err_at_peak(&fast.lm_power_pa2, &refm.lm_power_pa2) < 1e-4);
}

#[test]
fn cycle_statistics_match_a_direct_computation() {
    let tr = autd3();
    let model = FieldModel::new(&tr, Directivity::T4010A1, Medium::default(), None).unwrap();
    let k = model.wavenumber_rad_per_mm();
    let steps = 7;
    let c = [0.0, 0.0, 150.0];
    let mut ph = Vec::new();
    for s in 0..steps {
        let a = 2.0 * PI * s as f64 / steps as f64;
        ph.extend(quantise(&focus_rad(
            &tr,
            k,
            [c[0] + 4.0 * a.cos(), c[1] + 4.0 * a.sin(), c[2]],
        )));
    }
    let plane = plane_around(c, 5.0, 2.5);
    let m = simulate_reference(&model, &plane, &ph, steps, Radiation { alpha: 1.0 }).unwrap();
    let fct = model.radiation_factor(1.0);
    // The point (+5, 0) mm: near the orbit at step 0.
    let (iu, iv) = (4, 2);
    let p = plane.point(iu, iv);
    let series: Vec<f64> = (0..steps)
        .map(|s| {
            let d = drive_from_u8(&ph[s * tr.len()..(s + 1) * tr.len()]);
            fct * model.pressure(p, &d).norm_sqr()
        })
        .collect();
    let mean = series.iter().sum::<f64>() / steps as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for (s, v) in series.iter().enumerate() {
        let a = 2.0 * PI * s as f64 / steps as f64;
        re += v * a.cos();
        im -= v * a.sin();
    }
    let a1 = 2.0 * (re * re + im * im).sqrt() / steps as f64;
    let i = iv * m.nu + iu;
    assert!((m.mean_pressure_pa[i] - mean).abs() <= 1e-12 * mean);
    assert!((m.lm_power_pa2[i] - a1 * a1 / 2.0).abs() <= 1e-9 * a1 * a1);
    assert!((m.max_pressure_pa[i] - series.iter().cloned().fold(0.0, f64::max)).abs() < 1e-9);
    assert!((m.pressure_pa[i] - series[0]).abs() <= 1e-12 * series[0]);
    // A point swept by a moving focus varies at the LM frequency.
    assert!(m.lm_power_pa2[i] > 0.01 * mean * mean);
}

#[test]
fn disk_force_integrates_area() {
    let plane = plane_around([0.0; 3], 10.0, 0.2);
    let map = vec![1.0; plane.nu() * plane.nv()];
    let (f, clipped) = disk_force_n(&plane, &map, [0.0, 0.0], 15.0);
    let want = PI * 7.5e-3 * 7.5e-3;
    assert!((f - want).abs() < 0.01 * want, "{f} vs {want}");
    assert!(!clipped);
    let (_, clipped) = disk_force_n(&plane, &map, [5.0, 0.0], 15.0);
    assert!(clipped);
}

#[test]
fn bad_inputs_are_errors() {
    let tr = autd3();
    let m = Medium::default();
    assert_eq!(
        FieldModel::new(&[], Directivity::Omni, m, None).unwrap_err(),
        FieldError::NoTransducers
    );
    let bad_c = Medium {
        sound_speed_m_s: f64::NAN,
        ..m
    };
    assert!(FieldModel::new(&tr, Directivity::Omni, bad_c, None).is_err());
    let flat = Reflector {
        point_mm: [0.0; 3],
        normal: [0.0; 3],
    };
    assert_eq!(
        FieldModel::new(&tr, Directivity::Omni, m, Some(flat)).unwrap_err(),
        FieldError::BadReflector
    );
    let through = Reflector {
        point_mm: [0.0; 3],
        normal: Z,
    };
    assert_eq!(
        FieldModel::new(&tr, Directivity::Omni, m, Some(through)).unwrap_err(),
        FieldError::ReflectorHidesArray
    );
    let model = FieldModel::new(&tr, Directivity::Omni, m, None).unwrap();
    let plane = plane_around([0.0, 0.0, 100.0], 1.0, 0.5);
    let r = Radiation::default();
    assert!(matches!(
        simulate(&model, &plane, &[0; 10], 1, r),
        Err(FieldError::BadSequence { .. })
    ));
    let ph = vec![0u8; tr.len()];
    let skew = ObservationPlane {
        v: [1.0, 1.0, 0.0],
        ..plane
    };
    assert!(matches!(
        simulate(&model, &skew, &ph, 1, r),
        Err(FieldError::BadPlane(_))
    ));
    let huge = ObservationPlane {
        step_mm: 1e-4,
        ..plane
    };
    assert!(matches!(
        simulate(&model, &huge, &ph, 1, r),
        Err(FieldError::BadPlane(_))
    ));
    assert!(matches!(
        simulate(&model, &plane, &ph, 1, Radiation { alpha: -1.0 }),
        Err(FieldError::BadAlpha(_))
    ));
}
