//! Phase error of the device's centroid correction against an exact f64
//! re-plan, for one focus and for four foci on an LM circle, at centroid
//! offsets of 1, 3, 5 and 10 mm. Four AUTD3 boards (996 transducers).
//!
//! `cargo test --release -p lm-fw-core --test correction_accuracy -- --nocapture`
//! prints the table that goes to BENCHMARKS.md.

use std::f64::consts::PI;

use lm_fw_core::correction::{apply_offsets, compute_offsets};

const PITCH_UM: f64 = 10_160.0;
const SOUND_M_S: f64 = 340.0;

/// Four AUTD3 boards (18 × 14 minus 3 screw holes each) in a 2 × 2 layout,
/// z = 0, µm.
fn array() -> Vec<[i32; 3]> {
    let mut v = Vec::new();
    for (bx, by) in [
        (0.0, 0.0),
        (192_000.0, 0.0),
        (0.0, 151_400.0),
        (192_000.0, 151_400.0),
    ] {
        for y in 0..14 {
            for x in 0..18 {
                if y == 1 && (x == 1 || x == 2 || x == 16) {
                    continue;
                }
                v.push([
                    (bx + f64::from(x) * PITCH_UM).round() as i32,
                    (by + f64::from(y) * PITCH_UM).round() as i32,
                    0,
                ]);
            }
        }
    }
    assert_eq!(v.len(), 996);
    v
}

fn k_rad_per_um() -> f64 {
    2.0 * PI * 40_000.0 / (SOUND_M_S * 1e6)
}

fn dist(a: [i32; 3], b: [f64; 3]) -> f64 {
    (0..3)
        .map(|i| (f64::from(a[i]) - b[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn to_u8(phi: f64) -> u8 {
    ((phi / (2.0 * PI) * 256.0).round() as i64).rem_euclid(256) as u8
}

/// Exact multi-focus synthesis: φ = arg Σ exp(−j k r_i) (one focus: −k r).
fn plan(xs: &[[i32; 3]], foci: &[[f64; 3]]) -> Vec<u8> {
    let k = k_rad_per_um();
    xs.iter()
        .map(|x| {
            let (mut re, mut im) = (0.0, 0.0);
            for f in foci {
                let a = -k * dist(*x, *f);
                re += a.cos();
                im += a.sin();
            }
            to_u8(im.atan2(re))
        })
        .collect()
}

/// Normalised pressure amplitude at `f` (unit emitters, 1/r spreading).
fn amplitude_at(xs: &[[i32; 3]], phases: &[u8], f: [f64; 3]) -> f64 {
    let k = k_rad_per_um();
    let (mut re, mut im, mut norm) = (0.0, 0.0, 0.0);
    for (x, p) in xs.iter().zip(phases) {
        let r = dist(*x, f);
        let a = k * r + f64::from(*p) / 256.0 * 2.0 * PI;
        re += a.cos() / r;
        im += a.sin() / r;
        norm += 1.0 / r;
    }
    (re * re + im * im).sqrt() / norm
}

struct Row {
    max_lsb: i32,
    mean_lsb: f64,
    rms_rad: f64,
    amp_ratio_min: f64,
}

/// Compares corrected phases with the exact re-plan for foci on a 3 mm
/// circle (8 rotation angles) shifted by `shift_mm` in 6 directions.
fn compare(xs: &[[i32; 3]], pos: &[u8], n_foci: usize, shift_mm: f64) -> Row {
    let c0 = [192_000.0 + 86_360.0, 151_400.0 + 66_040.0, 200_000.0];
    let c0_um = c0.map(|v: f64| v.round() as i32);
    let c0 = c0_um.map(f64::from);
    let dirs = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.577, 0.577, 0.577],
        [-0.707, 0.707, 0.0],
    ];
    let (mut max, mut sum, mut sq, mut n) = (0i32, 0f64, 0f64, 0usize);
    let mut amp_min = f64::MAX;
    let mut offsets = vec![0u8; xs.len()];
    let mut out = vec![0u8; xs.len()];
    for step in 0..8 {
        let theta = step as f64 * PI / 4.0;
        let foci: Vec<[f64; 3]> = (0..n_foci)
            .map(|i| {
                let a = theta + i as f64 * 2.0 * PI / n_foci as f64;
                [c0[0] + 3000.0 * a.cos(), c0[1] + 3000.0 * a.sin(), c0[2]]
            })
            .collect();
        let planned = plan(xs, &foci);
        for d in dirs {
            let s = d.map(|v| v * shift_mm * 1000.0);
            let c_um = [0, 1, 2].map(|i| (c0[i] + s[i]).round() as i32);
            let s = [0, 1, 2].map(|i| f64::from(c_um[i]) - c0[i]);
            let moved: Vec<[f64; 3]> = foci
                .iter()
                .map(|f| [f[0] + s[0], f[1] + s[1], f[2] + s[2]])
                .collect();
            let exact = plan(xs, &moved);
            compute_offsets(pos, c0_um, c_um, SOUND_M_S as f32, &mut offsets);
            apply_offsets(&planned, &offsets, &mut out);
            for (a, b) in out.iter().zip(&exact) {
                let e = i32::from(a.wrapping_sub(*b) as i8);
                max = max.max(e.abs());
                sum += f64::from(e.abs());
                let rad = f64::from(e) / 256.0 * 2.0 * PI;
                sq += rad * rad;
                n += 1;
            }
            for f in &moved {
                let ratio = amplitude_at(xs, &out, *f) / amplitude_at(xs, &exact, *f);
                amp_min = amp_min.min(ratio);
            }
        }
    }
    Row {
        max_lsb: max,
        mean_lsb: sum / n as f64,
        rms_rad: (sq / n as f64).sqrt(),
        amp_ratio_min: amp_min,
    }
}

#[test]
fn correction_error_against_exact_replan() {
    let xs = array();
    let pos: Vec<u8> = xs
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    println!(
        "| foci | offset | max err (LSB) | mean err (LSB) | RMS err (rad) | min focal amplitude vs exact |"
    );
    println!("|---|---|---|---|---|---|");
    for n_foci in [1, 4] {
        for shift in [0.0, 1.0, 3.0, 5.0, 10.0] {
            let r = compare(&xs, &pos, n_foci, shift);
            println!(
                "| {n_foci} | {shift} mm | {} | {:.3} | {:.4} | {:.4} |",
                r.max_lsb, r.mean_lsb, r.rms_rad, r.amp_ratio_min
            );
            if shift == 0.0 {
                // No shift: the offsets are zero and the plan is unchanged.
                assert_eq!(r.max_lsb, 0);
            }
            // The correction keeps the focus: ≥ 95 % of the re-planned
            // focal pressure at every offset up to 10 mm.
            assert!(
                r.amp_ratio_min > 0.95,
                "{n_foci} foci at {shift} mm: {}",
                r.amp_ratio_min
            );
            if shift <= 1.0 {
                assert!(
                    r.mean_lsb < 1.5,
                    "{n_foci} foci at {shift} mm: mean {}",
                    r.mean_lsb
                );
            }
        }
    }
}
